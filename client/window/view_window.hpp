// palpview's window: a GLFW window whose OpenGL context hosts VTK through a
// vtkGenericOpenGLRenderWindow, and the forwarding of GLFW's input events to callbacks.
//
// Data flow: GLFW (X11 window, OpenGL >= 3.2 core context) -> vtkGenericOpenGLRenderWindow
// (VTK renders into its own framebuffer and blits into the GLFW context; WindowFrameEvent swaps
// the GLFW buffers) ; GLFW input events -> the callbacks in ViewEvents (main maps them to the
// camera, windowing or the controller). A hidden window (visible = false) serves --screenshot.
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <string>

class vtkRenderWindow;

namespace palp::view {

struct WindowOptions {
  int width = 1280, height = 800;
  bool visible = true;
  std::string title = "palpview";
};

// Input callbacks; GLFW key and modifier codes are passed through (GLFW_KEY_*, GLFW_MOD_*).
struct ViewEvents {
  std::function<void(int button, bool pressed, double x, double y, int mods)> mouse_button;
  std::function<void(double x, double y)> cursor;
  std::function<void(double dy, int mods)> scroll;
  std::function<void(int key, int mods)> key;  // press and repeat
  std::function<void(int width, int height)> resize;
};

class ViewWindow {
 public:
  // ResourceError when there is no display or no usable OpenGL context.
  explicit ViewWindow(const WindowOptions& options);
  ~ViewWindow();
  ViewWindow(const ViewWindow&) = delete;
  ViewWindow& operator=(const ViewWindow&) = delete;

  vtkRenderWindow* render_window();
  void set_events(ViewEvents events);
  void poll_events();
  bool should_close() const;
  void request_close();
  std::array<int, 2> framebuffer_size() const;
  // Whether a modifier bit (GLFW_MOD_*) is held by the keyboard right now.
  bool key_down(int glfw_key) const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace palp::view
