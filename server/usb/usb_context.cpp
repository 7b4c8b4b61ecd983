// The libusb context, its event thread and the hot-plug-driven device link: see usb_context.hpp.
//
// Event thread: libusb_handle_events_timeout_completed (20 ms) -> posted tasks -> (no hot-plug
// support: a bus scan every 0.5 s). Hot-plug callbacks only post a task (libusb forbids opening
// a device inside them). A link's state machine runs entirely on this thread:
//   Absent --arrival / start--> open, claim, on_open --ok--> Present (IN transfers in flight)
//          \--EACCES, busy, handshake refused--> Fault (until the device arrives again)
//   Present --left / NO_DEVICE / stop--> cancel all transfers --all returned--> close -> Absent
// The state is an atomic, set to Absent before anything else when the device goes, so a reader
// in another thread sees the loss at once.
#include "usb/usb_context.hpp"

#include <libusb.h>
#include <time.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <future>

#include "base/errors.hpp"

namespace palp::usb {
namespace {

std::int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

bool parse_hex16(std::string_view text, std::uint16_t& out) {
  if (text.empty() || text.size() > 4) return false;
  unsigned value = 0;
  for (char c : text) {
    value <<= 4;
    if (c >= '0' && c <= '9')
      value |= unsigned(c - '0');
    else if (c >= 'a' && c <= 'f')
      value |= unsigned(c - 'a' + 10);
    else if (c >= 'A' && c <= 'F')
      value |= unsigned(c - 'A' + 10);
    else
      return false;
  }
  out = static_cast<std::uint16_t>(value);
  return true;
}

std::string node_of(libusb_device* device) {
  char node[64];
  std::snprintf(node, sizeof node, "/dev/bus/usb/%03u/%03u", libusb_get_bus_number(device),
                libusb_get_device_address(device));
  return node;
}

}  // namespace

UsbId parse_usb_id(std::string_view text, std::string_view what) {
  const auto colon = text.find(':');
  UsbId id;
  if (colon == std::string_view::npos || !parse_hex16(text.substr(0, colon), id.vendor) ||
      !parse_hex16(text.substr(colon + 1), id.product))
    throw UsageError(std::string(what) +
                     " must be two hex numbers VID:PID (like 1209:0001), not '" +
                     std::string(text) + "'");
  return id;
}

std::string to_string(UsbId id) {
  char text[16];
  std::snprintf(text, sizeof text, "%04x:%04x", id.vendor, id.product);
  return text;
}

std::string permission_error_message(UsbId id, std::string_view node) {
  return "permission denied opening USB device " + to_string(id) + " (" + std::string(node) +
         "): install the udev rule " + kUdevRulePath + " (sudo cp " + kUdevRulePath +
         " /etc/udev/rules.d/ && sudo udevadm control --reload-rules && sudo udevadm trigger), "
         "then replug the device";
}

std::string error_text(int libusb_error) {
  return std::string(libusb_error_name(libusb_error)) + " (" + libusb_strerror(libusb_error) + ")";
}

// ---------------------------------------------------------------------------------------------
// UsbContext

struct UsbContext::Watch {
  UsbContext* owner = nullptr;
  int id = 0;
  UsbId usb_id;
  HotplugCallback callback;
  libusb_hotplug_callback_handle handle = 0;
  bool registered = false;
  bool active = true;  // event thread only
};

UsbContext::UsbContext() {
  const int rc = libusb_init(&context_);
  if (rc != 0) throw ResourceError("cannot initialise libusb: " + error_text(rc));
  has_hotplug_ = libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG) != 0;
  try {
    thread_ = std::thread([this] { run(); });
  } catch (const std::system_error& e) {
    libusb_exit(context_);
    throw ResourceError(std::string("cannot start the USB event thread: ") + e.what());
  }
}

UsbContext::~UsbContext() {
  stop_.store(true, std::memory_order_release);
  libusb_interrupt_event_handler(context_);
  if (thread_.joinable()) thread_.join();
  for (auto& watch : watches_)
    if (watch->registered) libusb_hotplug_deregister_callback(context_, watch->handle);
  watches_.clear();
  libusb_exit(context_);
}

void UsbContext::run() {
  while (!stop_.load(std::memory_order_acquire)) {
    timeval timeout{0, 20'000};
    libusb_handle_events_timeout_completed(context_, &timeout, nullptr);
    run_tasks();
    if (!has_hotplug_) scan_without_hotplug();
  }
  run_tasks();
}

void UsbContext::run_tasks() {
  std::vector<std::function<void()>> tasks;
  {
    const std::lock_guard lock(mutex_);
    tasks.swap(tasks_);
  }
  for (auto& task : tasks) task();
}

void UsbContext::post(std::function<void()> task) {
  {
    const std::lock_guard lock(mutex_);
    tasks_.push_back(std::move(task));
  }
  libusb_interrupt_event_handler(context_);
}

void UsbContext::run_sync(const std::function<void()>& task) {
  if (on_event_thread() || !thread_.joinable()) {
    task();
    return;
  }
  std::promise<void> done;
  std::future<void> finished = done.get_future();
  post([&] {
    task();
    done.set_value();
  });
  finished.wait();
}

int UsbContext::hotplug_trampoline(libusb_context* /*ctx*/, libusb_device* device, int event,
                                   void* user_data) {
  auto* watch = static_cast<Watch*>(user_data);
  const bool arrived = event == LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED;
  libusb_ref_device(device);
  UsbContext* owner = watch->owner;
  const int id = watch->id;
  owner->post([owner, id, device, arrived] {
    std::shared_ptr<Watch> target;
    {
      const std::lock_guard lock(owner->mutex_);
      for (auto& w : owner->watches_)
        if (w->id == id) target = w;
    }
    if (target && target->active) target->callback(device, arrived);
    libusb_unref_device(device);
  });
  return 0;  // stay registered
}

int UsbContext::watch(UsbId id, HotplugCallback callback) {
  auto watch = std::make_shared<Watch>();
  watch->owner = this;
  watch->usb_id = id;
  watch->callback = std::move(callback);
  {
    const std::lock_guard lock(mutex_);
    watch->id = next_watch_++;
    watches_.push_back(watch);
  }
  if (has_hotplug_) {
    const int rc = libusb_hotplug_register_callback(
        context_,
        static_cast<libusb_hotplug_event>(LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED |
                                          LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT),
        static_cast<libusb_hotplug_flag>(0), id.vendor, id.product, LIBUSB_HOTPLUG_MATCH_ANY,
        [](libusb_context* ctx, libusb_device* device, libusb_hotplug_event event,
           void* user_data) { return hotplug_trampoline(ctx, device, int(event), user_data); },
        watch.get(), &watch->handle);
    if (rc != 0) {
      unwatch(watch->id);
      throw ResourceError("cannot watch USB hot-plug for " + to_string(id) + ": " + error_text(rc));
    }
    watch->registered = true;
  }
  return watch->id;
}

void UsbContext::unwatch(int watch_id) {
  run_sync([&] {
    const std::lock_guard lock(mutex_);
    for (auto it = watches_.begin(); it != watches_.end(); ++it) {
      if ((*it)->id != watch_id) continue;
      (*it)->active = false;
      if ((*it)->registered) libusb_hotplug_deregister_callback(context_, (*it)->handle);
      watches_.erase(it);
      return;
    }
  });
}

void UsbContext::scan_without_hotplug() {
  const std::int64_t now = now_ns();
  if (now < next_scan_ns_) return;
  next_scan_ns_ = now + 500'000'000;
  std::vector<std::shared_ptr<Watch>> watches;
  {
    const std::lock_guard lock(mutex_);
    watches = watches_;
  }
  libusb_device** list = nullptr;
  const ssize_t n = libusb_get_device_list(context_, &list);
  for (ssize_t i = 0; i < n; ++i) {
    libusb_device_descriptor desc{};
    if (libusb_get_device_descriptor(list[i], &desc) != 0) continue;
    for (auto& w : watches)
      if (w->active && desc.idVendor == w->usb_id.vendor && desc.idProduct == w->usb_id.product)
        w->callback(list[i], true);
  }
  if (list) libusb_free_device_list(list, 1);
}

// ---------------------------------------------------------------------------------------------
// UsbLink

UsbLink::UsbLink(std::shared_ptr<UsbContext> context, LinkConfig config)
    : context_(std::move(context)), config_(std::move(config)) {
  if (!context_) throw UsageError("USB link without a context");
  if (config_.in_transfers < 1) config_.in_transfers = 1;
  for (int i = 0; i < config_.in_transfers; ++i) {
    auto slot = std::make_unique<Slot>();
    slot->link = this;
    slot->buffer.resize(config_.in_packet_size);
    slot->transfer = libusb_alloc_transfer(0);
    if (!slot->transfer) throw ResourceError("cannot allocate a USB transfer");
    in_slots_.push_back(std::move(slot));
  }
  if (config_.out_endpoint != 0) {
    for (int i = 0; i < std::max(config_.out_transfers, 1); ++i) {
      auto slot = std::make_unique<Slot>();
      slot->link = this;
      slot->buffer.resize(config_.out_packet_size);
      slot->transfer = libusb_alloc_transfer(0);
      if (!slot->transfer) throw ResourceError("cannot allocate a USB transfer");
      out_slots_.push_back(std::move(slot));
    }
  }
  set_message("waiting for USB device " + to_string(config_.id));
}

UsbLink::~UsbLink() {
  stop();
  for (auto& slot : in_slots_) libusb_free_transfer(slot->transfer);
  for (auto& slot : out_slots_) libusb_free_transfer(slot->transfer);
}

std::string UsbLink::message() const {
  const std::lock_guard lock(message_mutex_);
  return message_;
}

void UsbLink::set_message(std::string text) {
  const std::lock_guard lock(message_mutex_);
  message_ = std::move(text);
}

void UsbLink::start() {
  context_->run_sync([this] { started_ = true; });
  watch_id_ = context_->watch(
      config_.id, [this](libusb_device* device, bool arrived) { on_hotplug(device, arrived); });
  context_->post([this] { reconcile(); });
}

void UsbLink::stop() {
  bool was_started = false;
  context_->run_sync([&] {
    was_started = started_;
    started_ = false;
  });
  if (!was_started) return;
  context_->unwatch(watch_id_);
  watch_id_ = 0;
  context_->run_sync([this] {
    if (handle_ && !closing_) begin_close(LinkState::Absent, "stopped");
  });
  // Transfers come back cancelled within a few event passes; a device that never returns them
  // is closed anyway after a second (libusb then drops them from its in-flight list).
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(1);
  for (;;) {
    bool open = false;
    const bool late = std::chrono::steady_clock::now() > give_up;
    context_->run_sync([&] {
      if (handle_ && late) {
        in_flight_ = 0;
        finish_close();
      }
      open = handle_ != nullptr;
    });
    if (!open) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  state_.store(LinkState::Absent, std::memory_order_release);
  // Tasks this link posted (a reconcile after the close) run before this returns.
  context_->run_sync([] {});
  context_->run_sync([] {});
}

void UsbLink::on_hotplug(libusb_device* device, bool arrived) {
  if (!started_) return;
  if (arrived) {
    refused_ = false;  // a new arrival gets a new chance (the udev rule may be installed now)
    if (libusb_get_bus_number(device) == closed_bus_ &&
        libusb_get_device_address(device) == closed_address_)
      closed_bus_ = closed_address_ = 0;  // the same address is back: a new device
    reconcile();
    return;
  }
  if (handle_ && device == device_) {
    removals_.fetch_add(1, std::memory_order_relaxed);
    begin_close(LinkState::Absent, "USB device " + to_string(config_.id) + " unplugged");
  } else if (!handle_ && state() == LinkState::Fault) {
    refused_ = false;
    state_.store(LinkState::Absent, std::memory_order_release);
    set_message("USB device " + to_string(config_.id) + " unplugged");
  }
}

void UsbLink::reconcile() {
  if (!started_ || handle_ || refused_) return;
  libusb_device** list = nullptr;
  const ssize_t n = libusb_get_device_list(context_->raw(), &list);
  libusb_device* found = nullptr;
  unsigned matches = 0;  // the match_index-th device of this VID:PID is the one
  for (ssize_t i = 0; i < n && !found; ++i) {
    libusb_device_descriptor desc{};
    // The device just closed after a removal may still be listed until libusb's hot-plug thread
    // catches up: it is not opened again (a replugged device has a new address).
    if (libusb_get_bus_number(list[i]) == closed_bus_ &&
        libusb_get_device_address(list[i]) == closed_address_)
      continue;
    if (libusb_get_device_descriptor(list[i], &desc) == 0 && desc.idVendor == config_.id.vendor &&
        desc.idProduct == config_.id.product && matches++ == config_.match_index)
      found = list[i];
  }
  if (found) try_open(found);
  if (list) libusb_free_device_list(list, 1);
}

void UsbLink::try_open(libusb_device* device) {
  const std::string node = node_of(device);
  const std::string name = "USB device " + to_string(config_.id) + " at " + node;
  auto refuse = [&](std::string why) {
    refused_ = true;
    state_.store(LinkState::Fault, std::memory_order_release);
    set_message(std::move(why));
  };
  libusb_device_handle* handle = nullptr;
  int rc = libusb_open(device, &handle);
  if (rc == LIBUSB_ERROR_ACCESS) return refuse(permission_error_message(config_.id, node));
  if (rc == LIBUSB_ERROR_NO_DEVICE || rc == LIBUSB_ERROR_NOT_FOUND) return;  // already gone
  if (rc != 0) return refuse("cannot open " + name + ": " + error_text(rc));
  libusb_set_auto_detach_kernel_driver(handle, 1);  // NOT_SUPPORTED is fine
  rc = libusb_claim_interface(handle, config_.interface_number);
  if (rc != 0) {
    libusb_close(handle);
    if (rc == LIBUSB_ERROR_NO_DEVICE) return;
    if (rc == LIBUSB_ERROR_ACCESS) return refuse(permission_error_message(config_.id, node));
    if (rc == LIBUSB_ERROR_BUSY)
      return refuse(name + ": interface " + std::to_string(config_.interface_number) +
                    " is claimed by another program (another palpd?)");
    return refuse("cannot claim " + name + ": " + error_text(rc));
  }
  if (config_.on_open) {
    std::string why;
    try {
      why = config_.on_open(handle);
    } catch (const std::exception& e) {
      why = e.what();
    }
    if (!why.empty()) {
      libusb_release_interface(handle, config_.interface_number);
      libusb_close(handle);
      return refuse(name + ": " + why);
    }
  }
  handle_ = handle;
  device_ = device;
  closing_ = false;
  in_flight_ = 0;
  for (auto& slot : out_slots_) slot->busy = false;
  for (auto& slot : in_slots_) {
    auto fill = config_.interrupt ? libusb_fill_interrupt_transfer : libusb_fill_bulk_transfer;
    fill(slot->transfer, handle_, config_.in_endpoint, slot->buffer.data(),
         static_cast<int>(slot->buffer.size()), &UsbLink::in_callback, slot.get(), 0);
    rc = libusb_submit_transfer(slot->transfer);
    if (rc != 0) {
      begin_close(rc == LIBUSB_ERROR_NO_DEVICE ? LinkState::Absent : LinkState::Fault,
                  "cannot stream from " + name + ": " + error_text(rc));
      return;
    }
    slot->busy = true;
    ++in_flight_;
  }
  opens_.fetch_add(1, std::memory_order_relaxed);
  state_.store(LinkState::Present, std::memory_order_release);
  set_message("streaming from " + name);
}

void UsbLink::begin_close(LinkState next, std::string why) {
  if (!handle_ || closing_) return;
  closing_ = true;
  after_close_ = next;
  state_.store(next, std::memory_order_release);  // first: readers see the loss at once
  set_message(std::move(why));
  if (next == LinkState::Fault) refused_ = true;
  if (config_.on_close) config_.on_close();
  for (auto& slot : in_slots_)
    if (slot->busy) libusb_cancel_transfer(slot->transfer);
  for (auto& slot : out_slots_)
    if (slot->busy) libusb_cancel_transfer(slot->transfer);
  if (in_flight_ == 0) context_->post([this] { finish_close(); });
}

void UsbLink::finish_close() {
  if (!handle_ || in_flight_ > 0) return;
  if (after_close_ == LinkState::Absent) {  // removed: remember where it was
    closed_bus_ = libusb_get_bus_number(device_);
    closed_address_ = libusb_get_device_address(device_);
  }
  libusb_release_interface(handle_, config_.interface_number);
  libusb_close(handle_);
  handle_ = nullptr;
  device_ = nullptr;
  closing_ = false;
  for (auto& slot : in_slots_) slot->busy = false;
  for (auto& slot : out_slots_) slot->busy = false;
  state_.store(after_close_, std::memory_order_release);
  // The device may be back already (a quick replug) or its arrival may have been seen while
  // closing: look again.
  if (after_close_ == LinkState::Absent) context_->post([this] { reconcile(); });
}

void UsbLink::in_callback(libusb_transfer* transfer) {
  auto* slot = static_cast<Slot*>(transfer->user_data);
  UsbLink& link = *slot->link;
  auto retire = [&] {
    slot->busy = false;
    if (--link.in_flight_ == 0 && link.closing_)
      link.context_->post([&link] { link.finish_close(); });
  };
  if (link.closing_) return retire();
  switch (transfer->status) {
    case LIBUSB_TRANSFER_COMPLETED:
      link.in_packets_.fetch_add(1, std::memory_order_relaxed);
      if (link.config_.on_in)
        link.config_.on_in(transfer->buffer, static_cast<std::size_t>(transfer->actual_length));
      break;
    case LIBUSB_TRANSFER_NO_DEVICE:
      retire();
      link.removals_.fetch_add(1, std::memory_order_relaxed);
      link.begin_close(LinkState::Absent,
                       "USB device " + to_string(link.config_.id) + " unplugged");
      return;
    case LIBUSB_TRANSFER_CANCELLED:
      return retire();
    default:  // timed out, stalled, overflow, error: try again
      break;
  }
  if (link.closing_) return retire();  // on_in may have closed the link
  const int rc = libusb_submit_transfer(transfer);
  if (rc == LIBUSB_ERROR_NO_DEVICE) {
    retire();
    link.removals_.fetch_add(1, std::memory_order_relaxed);
    link.begin_close(LinkState::Absent, "USB device " + to_string(link.config_.id) + " unplugged");
  } else if (rc != 0) {
    retire();
    link.begin_close(LinkState::Fault,
                     "USB device " + to_string(link.config_.id) + ": " + error_text(rc));
  }
}

void UsbLink::out_callback(libusb_transfer* transfer) {
  auto* slot = static_cast<Slot*>(transfer->user_data);
  UsbLink& link = *slot->link;
  slot->busy = false;
  --link.in_flight_;
  if (link.closing_) {
    if (link.in_flight_ == 0) link.context_->post([&link] { link.finish_close(); });
    return;
  }
  if (transfer->status == LIBUSB_TRANSFER_NO_DEVICE) {
    link.removals_.fetch_add(1, std::memory_order_relaxed);
    link.begin_close(LinkState::Absent, "USB device " + to_string(link.config_.id) + " unplugged");
  }
}

bool UsbLink::send(const std::uint8_t* data, std::size_t size) noexcept {
  if (!handle_ || closing_ || out_slots_.empty() || size > config_.out_packet_size) return false;
  Slot* free_slot = nullptr;
  for (auto& slot : out_slots_)
    if (!slot->busy) {
      free_slot = slot.get();
      break;
    }
  if (!free_slot) {
    out_dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  std::memcpy(free_slot->buffer.data(), data, size);
  auto fill = config_.interrupt ? libusb_fill_interrupt_transfer : libusb_fill_bulk_transfer;
  fill(free_slot->transfer, handle_, config_.out_endpoint, free_slot->buffer.data(),
       static_cast<int>(size), &UsbLink::out_callback, free_slot, config_.out_timeout_ms);
  if (libusb_submit_transfer(free_slot->transfer) != 0) {
    out_dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  free_slot->busy = true;
  ++in_flight_;
  out_packets_.fetch_add(1, std::memory_order_relaxed);
  return true;
}

}  // namespace palp::usb
