// GLFW host of a vtkGenericOpenGLRenderWindow (see view_window.hpp). VTK asks, through three
// events, to make the context current, whether it is current, and to present a frame; GLFW
// answers them. Input callbacks reach ViewEvents through the window's user pointer.
#include "window/view_window.hpp"

#include <GLFW/glfw3.h>
#include <vtkCallbackCommand.h>
#include <vtkCommand.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkNew.h>
#include <vtkSmartPointer.h>

#include <cstdlib>
#include <string>

#include "base/errors.hpp"

namespace palp::view {

namespace {

std::string g_last_glfw_error;

void on_glfw_error(int code, const char* description) {
  g_last_glfw_error = std::to_string(code) + ": " + (description ? description : "?");
}

}  // namespace

struct ViewWindow::Impl {
  GLFWwindow* window = nullptr;
  vtkSmartPointer<vtkGenericOpenGLRenderWindow> render_window;
  ViewEvents events;
  bool glfw_initialised = false;

  static Impl* of(GLFWwindow* w) { return static_cast<Impl*>(glfwGetWindowUserPointer(w)); }
  // GLFW up and an OpenGL 3.2 core window open, its context current; ResourceError if not.
  void open_window(const WindowOptions& options);
  // VTK's render window on the GLFW context: VTK's three context events answered by GLFW.
  void host_render_window();
  // GLFW's resize and input callbacks handed to `events`.
  void forward_input();
};

void ViewWindow::Impl::open_window(const WindowOptions& options) {
  const char* display = std::getenv("DISPLAY");
  if (!display || !*display)
    throw ResourceError(
        "palpview: no X display (DISPLAY is not set); run it under a virtual display: "
        "xvfb-run -a palpview ...");
  glfwSetErrorCallback(on_glfw_error);
  if (!glfwInit())
    throw ResourceError("palpview: cannot initialise GLFW (" + g_last_glfw_error + ")");
  glfw_initialised = true;
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 2);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_VISIBLE, options.visible ? GLFW_TRUE : GLFW_FALSE);
  glfwWindowHint(GLFW_DEPTH_BITS, 24);
  glfwWindowHint(GLFW_STENCIL_BITS, 8);
  glfwWindowHint(GLFW_ALPHA_BITS, 8);
  glfwWindowHint(GLFW_SAMPLES, 0);
  window = glfwCreateWindow(options.width, options.height, options.title.c_str(), nullptr, nullptr);
  if (!window) {
    glfwTerminate();
    glfw_initialised = false;
    throw ResourceError("palpview: cannot create an OpenGL 3.2 window (" + g_last_glfw_error + ")");
  }
  glfwSetWindowUserPointer(window, this);
  glfwMakeContextCurrent(window);
  glfwSwapInterval(0);  // never wait for vertical sync: the frame time is what it costs
}

void ViewWindow::Impl::host_render_window() {
  auto& rw = render_window;
  rw = vtkSmartPointer<vtkGenericOpenGLRenderWindow>::New();
  int fb_width = 0, fb_height = 0;
  glfwGetFramebufferSize(window, &fb_width, &fb_height);
  rw->SetSize(fb_width, fb_height);
  rw->SetOwnContext(false);
  rw->SetIsDirect(true);
  rw->SetSupportsOpenGL(true);
  rw->SetMapped(1);

  vtkNew<vtkCallbackCommand> make_current;
  make_current->SetClientData(window);
  make_current->SetCallback([](vtkObject*, unsigned long, void* client, void*) {
    glfwMakeContextCurrent(static_cast<GLFWwindow*>(client));
  });
  rw->AddObserver(vtkCommand::WindowMakeCurrentEvent, make_current);
  vtkNew<vtkCallbackCommand> is_current;
  is_current->SetClientData(window);
  is_current->SetCallback([](vtkObject*, unsigned long, void* client, void* call) {
    *static_cast<bool*>(call) = glfwGetCurrentContext() == static_cast<GLFWwindow*>(client);
  });
  rw->AddObserver(vtkCommand::WindowIsCurrentEvent, is_current);
  vtkNew<vtkCallbackCommand> frame;
  frame->SetClientData(window);
  frame->SetCallback([](vtkObject* caller, unsigned long, void* client, void*) {
    auto* generic = static_cast<vtkGenericOpenGLRenderWindow*>(caller);
    if (generic->GetSwapBuffers()) glfwSwapBuffers(static_cast<GLFWwindow*>(client));
  });
  rw->AddObserver(vtkCommand::WindowFrameEvent, frame);
  if (!rw->InitializeFromCurrentContext())
    throw ResourceError("palpview: VTK cannot use the window's OpenGL context (needs OpenGL 3.2)");
  rw->SetReadyForRendering(true);
}

void ViewWindow::Impl::forward_input() {
  glfwSetFramebufferSizeCallback(window, [](GLFWwindow* w, int width, int height) {
    Impl* self = Impl::of(w);
    self->render_window->SetSize(width, height);
    if (self->events.resize) self->events.resize(width, height);
  });
  glfwSetMouseButtonCallback(window, [](GLFWwindow* w, int button, int action, int mods) {
    Impl* self = Impl::of(w);
    if (!self->events.mouse_button) return;
    double x = 0, y = 0;
    glfwGetCursorPos(w, &x, &y);
    self->events.mouse_button(button, action == GLFW_PRESS, x, y, mods);
  });
  glfwSetCursorPosCallback(window, [](GLFWwindow* w, double x, double y) {
    Impl* self = Impl::of(w);
    if (self->events.cursor) self->events.cursor(x, y);
  });
  glfwSetScrollCallback(window, [](GLFWwindow* w, double, double dy) {
    Impl* self = Impl::of(w);
    if (!self->events.scroll) return;
    const int mods = (glfwGetKey(w, GLFW_KEY_LEFT_CONTROL) == GLFW_PRESS ||
                      glfwGetKey(w, GLFW_KEY_RIGHT_CONTROL) == GLFW_PRESS)
                         ? GLFW_MOD_CONTROL
                         : 0;
    self->events.scroll(dy, mods);
  });
  glfwSetKeyCallback(window, [](GLFWwindow* w, int key, int, int action, int mods) {
    Impl* self = Impl::of(w);
    if (self->events.key && action != GLFW_RELEASE) self->events.key(key, mods);
  });
}

ViewWindow::ViewWindow(const WindowOptions& options) : impl_(std::make_unique<Impl>()) {
  impl_->open_window(options);
  impl_->host_render_window();
  impl_->forward_input();
}

ViewWindow::~ViewWindow() {
  if (!impl_) return;
  if (impl_->render_window) {
    if (impl_->window) glfwMakeContextCurrent(impl_->window);
    impl_->render_window->Finalize();
    impl_->render_window = nullptr;
  }
  if (impl_->window) glfwDestroyWindow(impl_->window);
  if (impl_->glfw_initialised) glfwTerminate();
}

vtkRenderWindow* ViewWindow::render_window() {
  return impl_->render_window;
}

void ViewWindow::set_events(ViewEvents events) {
  impl_->events = std::move(events);
}

void ViewWindow::poll_events() {
  glfwPollEvents();
}

bool ViewWindow::should_close() const {
  return glfwWindowShouldClose(impl_->window) != 0;
}

void ViewWindow::request_close() {
  glfwSetWindowShouldClose(impl_->window, GLFW_TRUE);
}

std::array<int, 2> ViewWindow::framebuffer_size() const {
  int width = 0, height = 0;
  glfwGetFramebufferSize(impl_->window, &width, &height);
  return {width, height};
}

bool ViewWindow::key_down(int glfw_key) const {
  return glfwGetKey(impl_->window, glfw_key) == GLFW_PRESS;
}

}  // namespace palp::view
