// The in-process USB device emulator (see usb_emulator.hpp): a GObject ioctl handler attached to
// the emulated /dev/bus/usb node answers libusb's usbfs requests from the device's descriptors,
// the test's control handler, an IN packet queue per endpoint and the test's OUT handler.
//
// URB life: SUBMITURB keeps a reference to the resolved usbdevfs_urb; control and OUT URBs are
// answered at once (handlers called) and wait to be reaped; IN URBs wait until a packet is queued
// for their endpoint. REAPURB(NDELAY) hands back the oldest finished URB (EAGAIN when none);
// DISCARDURB finishes one with -ENOENT. After unplug() every request fails with ENODEV, which
// libusb treats as the device being gone.
#include "support/usb_emulator.hpp"

#include <linux/ioctl.h>
#include <linux/usbdevice_fs.h>
#include <time.h>
#include <umockdev.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace palp::usbemu {
namespace {

std::atomic<int> next_busnum{10};

void put16(std::vector<std::uint8_t>& out, std::uint16_t v) {
  out.push_back(static_cast<std::uint8_t>(v & 0xff));
  out.push_back(static_cast<std::uint8_t>(v >> 8));
}

std::string hex(const std::vector<std::uint8_t>& bytes) {
  static const char* digits = "0123456789abcdef";
  std::string s;
  for (std::uint8_t b : bytes) {
    s.push_back(digits[b >> 4]);
    s.push_back(digits[b & 15]);
  }
  return s;
}

std::string three_digits(int n) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "%03d", n);
  return buf;
}

gboolean on_handle_ioctl(UMockdevIoctlBase* /*handler*/, UMockdevIoctlClient* client,
                         gpointer user_data) {
  return static_cast<EmulatedUsbDevice*>(user_data)->handle_ioctl(client) ? TRUE : FALSE;
}

}  // namespace

std::vector<std::uint8_t> descriptor_blob(const DeviceSpec& spec) {
  std::vector<std::uint8_t> d;
  // Device descriptor (18 bytes).
  d.push_back(18);
  d.push_back(1);
  put16(d, spec.bcd_usb);
  d.push_back(spec.device_class);
  d.push_back(0);
  d.push_back(0);
  d.push_back(spec.max_packet0);
  put16(d, spec.vendor_id);
  put16(d, spec.product_id);
  put16(d, spec.bcd_device);
  d.push_back(0);  // iManufacturer
  d.push_back(0);  // iProduct
  d.push_back(0);  // iSerialNumber
  d.push_back(1);  // bNumConfigurations
  // Configuration descriptor, its total length patched below.
  const std::size_t config_at = d.size();
  d.push_back(9);
  d.push_back(2);
  put16(d, 0);
  d.push_back(static_cast<std::uint8_t>(spec.interfaces.size()));
  d.push_back(1);     // bConfigurationValue
  d.push_back(0);     // iConfiguration
  d.push_back(0x80);  // bus powered
  d.push_back(50);    // 100 mA
  for (const InterfaceSpec& itf : spec.interfaces) {
    d.push_back(9);
    d.push_back(4);
    d.push_back(itf.number);
    d.push_back(0);  // bAlternateSetting
    d.push_back(static_cast<std::uint8_t>(itf.endpoints.size()));
    d.push_back(itf.interface_class);
    d.push_back(itf.subclass);
    d.push_back(itf.protocol);
    d.push_back(0);
    d.insert(d.end(), itf.class_descriptor.begin(), itf.class_descriptor.end());
    for (const EndpointSpec& ep : itf.endpoints) {
      d.push_back(7);
      d.push_back(5);
      d.push_back(ep.address);
      d.push_back(ep.attributes);
      put16(d, ep.max_packet);
      d.push_back(ep.interval);
    }
  }
  const auto total = static_cast<std::uint16_t>(d.size() - config_at);
  d[config_at + 2] = static_cast<std::uint8_t>(total & 0xff);
  d[config_at + 3] = static_cast<std::uint8_t>(total >> 8);
  return d;
}

UsbTestbed::UsbTestbed() : testbed_(umockdev_testbed_new()) {
  if (!testbed_) throw std::runtime_error("umockdev_testbed_new failed");
}

UsbTestbed::~UsbTestbed() {
  g_object_unref(testbed_);
}

bool UsbTestbed::in_mock_environment() {
  // umockdev-wrapper preloads libumockdev-preload; umockdev_in_mock_environment() only turns
  // true once a testbed exists, so look at the preload list itself.
  const char* preload = std::getenv("LD_PRELOAD");
  return preload != nullptr && std::strstr(preload, "umockdev-preload") != nullptr;
}

EmulatedUsbDevice::EmulatedUsbDevice(UsbTestbed& testbed, DeviceSpec spec)
    : testbed_(testbed), spec_(std::move(spec)), descriptors_(descriptor_blob(spec_)) {
  busnum_ = spec_.busnum > 0 ? spec_.busnum : next_busnum.fetch_add(1);
  handler_ = umockdev_ioctl_base_new();
  g_signal_connect_after(handler_, "handle-ioctl", G_CALLBACK(on_handle_ioctl), this);
}

EmulatedUsbDevice::~EmulatedUsbDevice() {
  stop_in_stream();
  if (plugged()) unplug();
  for (const std::string& node : attached_nodes_)
    umockdev_testbed_detach_ioctl(testbed_.raw(), node.c_str(), nullptr);
  g_signal_handlers_disconnect_by_data(handler_, this);
  release_urbs();
  g_object_unref(handler_);
}

std::string EmulatedUsbDevice::devnode() const {
  return "/dev/bus/usb/" + three_digits(busnum_) + "/" + three_digits(devnum_.load());
}

std::string EmulatedUsbDevice::syspath() const {
  return "/sys/devices/usb" + std::to_string(busnum_);
}

void EmulatedUsbDevice::on_control(ControlHandler handler) {
  const std::lock_guard lock(mutex_);
  control_handler_ = std::move(handler);
}

void EmulatedUsbDevice::on_out(OutHandler handler) {
  const std::lock_guard lock(mutex_);
  out_handler_ = std::move(handler);
}

void EmulatedUsbDevice::queue_in(std::uint8_t endpoint, std::vector<std::uint8_t> packet) {
  const std::lock_guard lock(mutex_);
  auto& queue = in_queues_[endpoint];
  queue.push_back(std::move(packet));
  const auto limit = in_limits_.find(endpoint);
  if (limit != in_limits_.end()) {
    while (queue.size() > limit->second) {
      queue.pop_front();
      in_dropped_.fetch_add(1);
    }
  }
}

void EmulatedUsbDevice::clear_in(std::uint8_t endpoint) {
  const std::lock_guard lock(mutex_);
  in_queues_[endpoint].clear();
}

void EmulatedUsbDevice::start_in_stream(std::uint8_t endpoint, double rate_hz, InProducer producer,
                                        std::size_t max_queued) {
  stop_in_stream();
  {
    const std::lock_guard lock(mutex_);
    in_limits_[endpoint] = std::max<std::size_t>(max_queued, 1);
  }
  stream_stop_.store(false);
  const auto period_ns = static_cast<std::int64_t>(1e9 / rate_hz + 0.5);
  stream_thread_ = std::thread([this, endpoint, period_ns, producer = std::move(producer)] {
    timespec start{};
    clock_gettime(CLOCK_MONOTONIC, &start);
    const std::int64_t t0 = std::int64_t(start.tv_sec) * 1'000'000'000 + start.tv_nsec;
    for (std::uint64_t index = 0; !stream_stop_.load(); ++index) {
      const std::int64_t device_time = static_cast<std::int64_t>(index) * period_ns;
      const std::int64_t deadline = t0 + device_time;
      timespec ts{};
      ts.tv_sec = static_cast<time_t>(deadline / 1'000'000'000);
      ts.tv_nsec = static_cast<long>(deadline % 1'000'000'000);
      while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
      }
      if (!plugged()) continue;
      if (auto packet = producer(index, device_time)) queue_in(endpoint, std::move(*packet));
    }
  });
}

void EmulatedUsbDevice::stop_in_stream() {
  stream_stop_.store(true);
  if (stream_thread_.joinable()) stream_thread_.join();
}

void EmulatedUsbDevice::plug() {
  if (plugged()) return;
  if (plugs_.load() > 0) ++devnum_;  // a replugged device gets a new address, as on a real bus
  const std::string node = devnode();
  GError* error = nullptr;
  // The ioctl handler first, so libusb can open the node as soon as the "add" uevent arrives.
  if (!umockdev_testbed_attach_ioctl(testbed_.raw(), node.c_str(), handler_, &error)) {
    const std::string message = error ? error->message : "unknown error";
    g_clear_error(&error);
    throw std::runtime_error("umockdev_testbed_attach_ioctl " + node + ": " + message);
  }
  attached_nodes_.push_back(node);
  {
    const std::lock_guard lock(mutex_);
    for (auto& [endpoint, queue] : in_queues_) queue.clear();
  }
  plugged_.store(true);
  char ids[64];
  std::snprintf(ids, sizeof ids, "A: idVendor=%04x\\n\nA: idProduct=%04x\\n\n", spec_.vendor_id,
                spec_.product_id);
  const std::string b = std::to_string(busnum_), d = std::to_string(devnum_.load());
  const std::string record =
      "P: /devices/usb" + b + "\nN: " + node.substr(5) +
      "\nE: SUBSYSTEM=usb\nE: DRIVER=usb\nE: BUSNUM=" + three_digits(busnum_) +
      "\nE: DEVNUM=" + three_digits(devnum_.load()) + "\nE: DEVNAME=" + node +
      "\nE: DEVTYPE=usb_device\nA: bConfigurationValue=1\\n\nA: busnum=" + b +
      "\\n\nA: devnum=" + d + "\\n\n" + ids +
      "A: speed=12\\n\nH: descriptors=" + hex(descriptors_) + "\n";
  if (!umockdev_testbed_add_from_string(testbed_.raw(), record.c_str(), &error)) {
    const std::string message = error ? error->message : "unknown error";
    g_clear_error(&error);
    throw std::runtime_error("umockdev_testbed_add_from_string: " + message);
  }
  plugs_.fetch_add(1);
}

void EmulatedUsbDevice::unplug() {
  if (!plugged()) return;
  plugged_.store(false);
  {
    const std::lock_guard lock(mutex_);
    for (auto& [endpoint, queue] : in_queues_) queue.clear();
  }
  umockdev_testbed_uevent(testbed_.raw(), syspath().c_str(), "remove");
  umockdev_testbed_remove_device(testbed_.raw(), syspath().c_str());
}

void EmulatedUsbDevice::release_urbs() {
  const std::lock_guard lock(mutex_);
  for (Urb& urb : urbs_) umockdev_ioctl_data_unref(urb.data);
  urbs_.clear();
}

bool EmulatedUsbDevice::alive(UMockdevIoctlClient* client) const {
  if (!plugged()) return false;
  const gchar* node = umockdev_ioctl_client_get_devnode(client);
  return node != nullptr && devnode() == node;
}

bool EmulatedUsbDevice::handle_ioctl(UMockdevIoctlClient* client) {
  const unsigned long request = umockdev_ioctl_client_get_request(client);
  UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);
  // A handle opened before an unplug stays dead after the replug (that is a new node).
  if (!alive(client)) {
    // As the kernel after a disconnect: URBs still queued come back with -ESHUTDOWN (libusb:
    // LIBUSB_TRANSFER_NO_DEVICE), then every request fails with ENODEV.
    if (request == USBDEVFS_REAPURB || request == USBDEVFS_REAPURBNDELAY)
      return handle_reap(client, arg);
    umockdev_ioctl_client_complete(client, -1, ENODEV);
    return true;
  }
  switch (request) {
    case USBDEVFS_GET_CAPABILITIES: {
      UMockdevIoctlData* caps = umockdev_ioctl_data_resolve(arg, 0, sizeof(guint32), nullptr);
      const guint32 value = USBDEVFS_CAP_BULK_CONTINUATION | USBDEVFS_CAP_NO_PACKET_SIZE_LIM |
                            USBDEVFS_CAP_REAP_AFTER_DISCONNECT | USBDEVFS_CAP_ZERO_PACKET;
      std::memcpy(caps->data, &value, sizeof value);
      umockdev_ioctl_data_unref(caps);
      umockdev_ioctl_client_complete(client, 0, 0);
      return true;
    }
    case USBDEVFS_CLAIMINTERFACE:
    case USBDEVFS_DISCONNECT_CLAIM:  // libusb's auto-detach: no driver to detach, just claim
      claims_.fetch_add(1);
      umockdev_ioctl_client_complete(client, 0, 0);
      return true;
    case USBDEVFS_RELEASEINTERFACE:
    case USBDEVFS_SETINTERFACE:
    case USBDEVFS_SETCONFIGURATION:
    case USBDEVFS_CLEAR_HALT:
    case USBDEVFS_RESET:
    case USBDEVFS_RESETEP:
      umockdev_ioctl_client_complete(client, 0, 0);
      return true;
    case USBDEVFS_GETDRIVER:  // no kernel driver is bound to any interface
    case USBDEVFS_IOCTL:      // (USBDEVFS_DISCONNECT / CONNECT of a kernel driver)
      umockdev_ioctl_client_complete(client, -1, ENODATA);
      return true;
    case USBDEVFS_SUBMITURB:
      return handle_submit(client, arg);
    case USBDEVFS_REAPURB:
    case USBDEVFS_REAPURBNDELAY:
      return handle_reap(client, arg);
    case USBDEVFS_DISCARDURB:
      return handle_discard(client, arg);
    default:
      umockdev_ioctl_client_complete(client, -1, ENOTTY);
      return true;
  }
}

bool EmulatedUsbDevice::handle_submit(UMockdevIoctlClient* client, UMockdevIoctlData* arg) {
  UMockdevIoctlData* urb_data =
      umockdev_ioctl_data_resolve(arg, 0, sizeof(struct usbdevfs_urb), nullptr);
  auto* urb = reinterpret_cast<struct usbdevfs_urb*>(urb_data->data);
  UMockdevIoctlData* buffer =
      umockdev_ioctl_data_resolve(urb_data, G_STRUCT_OFFSET(struct usbdevfs_urb, buffer),
                                  std::size_t(urb->buffer_length), nullptr);
  Urb entry;
  entry.node = umockdev_ioctl_client_get_devnode(client);
  entry.data = urb_data;
  entry.client_addr = urb_data->client_addr;
  entry.type = urb->type;
  entry.endpoint = urb->endpoint;
  const bool in = (urb->endpoint & 0x80) != 0;

  if (urb->type == USBDEVFS_URB_TYPE_CONTROL) {
    if (urb->buffer_length < 8) {
      umockdev_ioctl_data_unref(buffer);
      umockdev_ioctl_data_unref(urb_data);
      umockdev_ioctl_client_complete(client, -1, EINVAL);
      return true;
    }
    const std::uint8_t* setup = buffer->data;
    ControlRequest request;
    request.request_type = setup[0];
    request.request = setup[1];
    request.value = static_cast<std::uint16_t>(setup[2] | (setup[3] << 8));
    request.index = static_cast<std::uint16_t>(setup[4] | (setup[5] << 8));
    request.length = static_cast<std::uint16_t>(setup[6] | (setup[7] << 8));
    if (!request.is_in())
      request.data.assign(setup + 8,
                          setup + 8 + std::min<int>(request.length, urb->buffer_length - 8));
    ControlHandler handler;
    {
      const std::lock_guard lock(mutex_);
      handler = control_handler_;
    }
    control_transfers_.fetch_add(1);
    ControlReply reply = handler ? handler(request) : ControlReply::stalled();
    entry.done = true;
    if (reply.stall) {
      entry.status = -EPIPE;
    } else if (request.is_in()) {
      const std::size_t n = std::min<std::size_t>(
          {reply.data.size(), request.length, std::size_t(urb->buffer_length - 8)});
      // Same address space: the data stage goes straight into the caller's buffer (after the
      // 8-byte setup packet), as the kernel would copy it.
      std::memcpy(static_cast<std::uint8_t*>(urb->buffer) + 8, reply.data.data(), n);
      entry.actual_length = static_cast<int>(n);
    } else {
      entry.actual_length = static_cast<int>(request.data.size());
    }
  } else if (!in) {
    std::vector<std::uint8_t> packet(buffer->data, buffer->data + urb->buffer_length);
    OutHandler handler;
    {
      const std::lock_guard lock(mutex_);
      handler = out_handler_;
    }
    out_received_.fetch_add(1);
    if (handler) handler(urb->endpoint, packet);
    entry.done = true;
    entry.actual_length = urb->buffer_length;
  }
  umockdev_ioctl_data_unref(buffer);
  {
    const std::lock_guard lock(mutex_);
    urbs_.push_back(entry);
  }
  umockdev_ioctl_client_complete(client, 0, 0);
  return true;
}

bool EmulatedUsbDevice::handle_reap(UMockdevIoctlClient* client, UMockdevIoctlData* arg) {
  Urb reaped;
  bool found = false;
  const std::string node = umockdev_ioctl_client_get_devnode(client);
  const bool live = alive(client);
  {
    const std::lock_guard lock(mutex_);
    for (auto it = urbs_.begin(); it != urbs_.end(); ++it) {
      if (it->node != node) continue;  // another handle's URB
      if (!live && !it->done) {
        it->done = true;
        it->status = -ESHUTDOWN;
        it->actual_length = 0;
      }
      if (!it->done && (it->endpoint & 0x80) && it->type != USBDEVFS_URB_TYPE_CONTROL) {
        auto queue = in_queues_.find(it->endpoint);
        if (queue == in_queues_.end() || queue->second.empty()) continue;
        auto* urb = reinterpret_cast<struct usbdevfs_urb*>(it->data->data);
        const std::vector<std::uint8_t>& packet = queue->second.front();
        const std::size_t n = std::min<std::size_t>(packet.size(), std::size_t(urb->buffer_length));
        std::memcpy(urb->buffer, packet.data(), n);
        queue->second.pop_front();
        it->done = true;
        it->actual_length = static_cast<int>(n);
        it->status = 0;
        in_delivered_.fetch_add(1);
      }
      if (it->done) {
        reaped = *it;
        urbs_.erase(it);
        found = true;
        break;
      }
    }
  }
  if (!found) {
    umockdev_ioctl_client_complete(client, -1, live ? EAGAIN : ENODEV);
    return true;
  }
  auto* urb = reinterpret_cast<struct usbdevfs_urb*>(reaped.data->data);
  urb->actual_length = reaped.actual_length;
  urb->status = reaped.status;
  UMockdevIoctlData* pointer = umockdev_ioctl_data_resolve(arg, 0, sizeof(gpointer), nullptr);
  umockdev_ioctl_data_set_ptr(pointer, 0, reaped.data);
  umockdev_ioctl_data_unref(pointer);
  umockdev_ioctl_data_unref(reaped.data);
  umockdev_ioctl_client_complete(client, 0, 0);
  return true;
}

bool EmulatedUsbDevice::handle_discard(UMockdevIoctlClient* client, UMockdevIoctlData* arg) {
  const auto address = reinterpret_cast<unsigned long>(*reinterpret_cast<void**>(arg->data));
  bool found = false;
  {
    const std::lock_guard lock(mutex_);
    for (Urb& urb : urbs_) {
      if (urb.client_addr == address && !urb.done &&
          urb.node == umockdev_ioctl_client_get_devnode(client)) {
        urb.done = true;
        urb.status = -ENOENT;
        urb.actual_length = 0;
        found = true;
        break;
      }
    }
  }
  if (found)
    umockdev_ioctl_client_complete(client, 0, 0);
  else
    umockdev_ioctl_client_complete(client, -1, EINVAL);
  return true;
}

bool wait_until(const std::function<bool()>& condition, double timeout_s) {
  const auto end = std::chrono::steady_clock::now() +
                   std::chrono::microseconds(static_cast<std::int64_t>(timeout_s * 1e6));
  while (!condition()) {
    if (std::chrono::steady_clock::now() > end) return condition();
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

}  // namespace palp::usbemu
