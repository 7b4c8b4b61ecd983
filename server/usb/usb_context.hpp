// The shared libusb-1.0 layer of palpd's USB devices (open haptic protocol, SpaceMouse, ...).
//
//   UsbContext  one libusb context and the thread that runs all of its events: transfer
//               callbacks, hot-plug callbacks, and tasks posted to it. Nothing USB happens in the
//               haptic loop's thread.
//   UsbLink     one device by VID:PID on a context, through hot-plug: opens and claims it when
//               it appears (also when it was there before), runs the caller's handshake, keeps
//               IN transfers in flight on one endpoint and hands every IN packet to the caller;
//               OUT packets go back through send(). When the device vanishes (hot-plug "left" or
//               a transfer answering NO_DEVICE) the link says Absent at once, cancels and
//               closes, and opens the device again when it returns. A permission error (EACCES
//               on /dev/bus/usb) leaves the link in Fault with a message naming the udev rule.
//
// Data flow:
//   kernel usbfs ─► libusb (event thread) ─► UsbLink IN callback ─► LinkConfig::on_in(packet)
//       └─ the device parses the packet, publishes it to the loop (LatestBox / atomics) and may
//          answer with UsbLink::send() (OUT endpoint) in the same callback.
//
// Usage (a device's activate(); callbacks run on the context's event thread):
//   auto context = std::make_shared<palp::usb::UsbContext>();   // one per process is enough
//   palp::usb::LinkConfig config;
//   config.id = palp::usb::parse_usb_id("256f:c635");
//   config.interface_number = 0; config.in_endpoint = 0x81; config.in_packet_size = 64;
//   config.on_open = [](libusb_device_handle* h) -> std::string { return ""; };  // handshake
//   config.on_in = [](const std::uint8_t* data, std::size_t size) { ... };
//   config.on_close = [] { ... };                                  // device gone or stopped
//   palp::usb::UsbLink link(context, config);
//   link.start();   // returns at once; the device may come later
//   link.state();   // Present / Absent / Fault, any thread, lock-free
//   link.stop();    // blocks until the device is closed
// Callbacks must not block for long (they hold up every transfer of the context); on_open may
// make synchronous control transfers (it runs between event-handling passes).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "base/device_state.hpp"

struct libusb_context;
struct libusb_device;
struct libusb_device_handle;
struct libusb_transfer;

namespace palp::usb {

struct UsbId {
  std::uint16_t vendor = 0;
  std::uint16_t product = 0;
  bool operator==(const UsbId&) const = default;
};

// "VVVV:PPPP" in hex (1 to 4 digits each). UsageError otherwise; `what` names the option.
UsbId parse_usb_id(std::string_view text, std::string_view what = "VID:PID");
std::string to_string(UsbId id);  // "1209:0001"

// The udev rule file palp ships (deploy/udev/70-palp.rules).
inline constexpr const char* kUdevRulePath = "deploy/udev/70-palp.rules";
// One line for an EACCES on the device node: what to install and how to reload udev.
std::string permission_error_message(UsbId id, std::string_view node);
// libusb's name of an error code, with its text ("LIBUSB_ERROR_ACCESS (Access denied ...)").
std::string error_text(int libusb_error);

class UsbContext {
 public:
  // libusb_init and the event thread. ResourceError when libusb cannot start.
  UsbContext();
  ~UsbContext();  // stops the thread, then libusb_exit (every UsbLink must be gone)
  UsbContext(const UsbContext&) = delete;
  UsbContext& operator=(const UsbContext&) = delete;

  libusb_context* raw() const { return context_; }
  bool has_hotplug() const { return has_hotplug_; }
  bool on_event_thread() const { return std::this_thread::get_id() == thread_.get_id(); }

  // Runs `task` on the event thread, outside any libusb callback, soon.
  void post(std::function<void()> task);
  // Runs `task` on the event thread and waits for it (runs it at once when called there).
  void run_sync(const std::function<void()>& task);

  // Hot-plug watch for one VID:PID: `callback(device, arrived)` runs on the event thread through
  // post() (so it may open the device); the device is referenced for the call. Without hot-plug
  // support the bus is scanned every 0.5 s instead. Returns an id for unwatch().
  using HotplugCallback = std::function<void(libusb_device* device, bool arrived)>;
  int watch(UsbId id, HotplugCallback callback);
  void unwatch(int watch_id);  // from any thread; the callback is not called after it returns

 private:
  struct Watch;
  void run();
  void run_tasks();
  void scan_without_hotplug();
  static int hotplug_trampoline(libusb_context* ctx, libusb_device* device, int event,
                                void* user_data);

  libusb_context* context_ = nullptr;
  bool has_hotplug_ = false;
  std::atomic<bool> stop_{false};
  std::mutex mutex_;  // tasks_, watches_
  std::vector<std::function<void()>> tasks_;
  std::vector<std::shared_ptr<Watch>> watches_;
  int next_watch_ = 1;
  std::int64_t next_scan_ns_ = 0;
  std::thread thread_;
};

// A USB link's state, in the device states' vocabulary (base/device_state.hpp): Absent (not
// plugged in, or closed), Present (open, claimed, handshake done, streaming), Fault (plugged in
// but unusable: permission, busy, handshake refused); never Unknown.
using LinkState = palp::DeviceState;
using palp::to_string;

struct LinkConfig {
  UsbId id;
  int interface_number = 0;
  unsigned match_index = 0;  // with several devices of this VID:PID plugged in: which one (0: first)
  std::uint8_t in_endpoint = 0x81;
  std::uint8_t out_endpoint = 0;  // 0: no OUT endpoint
  bool interrupt = true;          // interrupt endpoints (false: bulk)
  std::size_t in_packet_size = 64;
  std::size_t out_packet_size = 64;
  int in_transfers = 4;   // IN transfers kept in flight
  int out_transfers = 8;  // OUT transfers in the pool
  unsigned out_timeout_ms = 100;
  // Event thread, after the interface is claimed and before streaming: a handshake (synchronous
  // control transfers allowed). Returns "" to go on, or why the device is refused (-> Fault).
  std::function<std::string(libusb_device_handle* handle)> on_open;
  // Event thread: one IN packet (the buffer is valid during the call only).
  std::function<void(const std::uint8_t* data, std::size_t size)> on_in;
  // Event thread: the device left, was refused or the link stops (after Present only).
  std::function<void()> on_close;
};

class UsbLink {
 public:
  UsbLink(std::shared_ptr<UsbContext> context, LinkConfig config);
  ~UsbLink();  // stop()
  UsbLink(const UsbLink&) = delete;
  UsbLink& operator=(const UsbLink&) = delete;

  void start();  // watches hot-plug; opens the device now when it is plugged in
  void stop();   // closes the device and stops watching; blocks until done

  // Any thread, lock-free.
  LinkState state() const noexcept { return state_.load(std::memory_order_acquire); }
  std::uint64_t opens() const noexcept { return opens_.load(std::memory_order_relaxed); }
  std::uint64_t in_packets() const noexcept { return in_packets_.load(std::memory_order_relaxed); }
  std::uint64_t out_packets() const noexcept {
    return out_packets_.load(std::memory_order_relaxed);
  }
  std::uint64_t out_dropped() const noexcept {
    return out_dropped_.load(std::memory_order_relaxed);
  }
  std::uint64_t removals() const noexcept { return removals_.load(std::memory_order_relaxed); }
  // The last event or error, for people (locks: not for the real-time thread).
  std::string message() const;

  // Event thread only (inside on_in / on_open): queues one OUT packet. False when the link is not
  // open, has no OUT endpoint, the packet is too long, or every OUT transfer is in flight.
  bool send(const std::uint8_t* data, std::size_t size) noexcept;

  const LinkConfig& config() const { return config_; }

 private:
  struct Slot {
    UsbLink* link = nullptr;
    libusb_transfer* transfer = nullptr;
    std::vector<std::uint8_t> buffer;
    bool busy = false;
  };
  void on_hotplug(libusb_device* device, bool arrived);
  void reconcile();
  void try_open(libusb_device* device);
  void begin_close(LinkState next, std::string why);
  void finish_close();
  void set_message(std::string text);
  static void in_callback(libusb_transfer* transfer);
  static void out_callback(libusb_transfer* transfer);

  std::shared_ptr<UsbContext> context_;
  LinkConfig config_;
  int watch_id_ = 0;

  // Event thread only.
  libusb_device_handle* handle_ = nullptr;
  libusb_device* device_ = nullptr;  // the open device (not referenced separately)
  bool closing_ = false;
  int in_flight_ = 0;
  std::int64_t close_started_ns_ = 0;
  LinkState after_close_ = LinkState::Absent;
  bool refused_ = false;  // Fault for the device now plugged in: wait for the next arrival
  std::uint8_t closed_bus_ = 0, closed_address_ = 0;  // where the last removed device was
  std::vector<std::unique_ptr<Slot>> in_slots_, out_slots_;

  std::atomic<LinkState> state_{LinkState::Absent};
  std::atomic<std::uint64_t> opens_{0}, in_packets_{0}, out_packets_{0}, out_dropped_{0},
      removals_{0};
  mutable std::mutex message_mutex_;
  std::string message_;
  bool started_ = false;
};

}  // namespace palp::usb
