// An in-process USB device emulator for tests, on umockdev: the code under test talks to it
// through real libusb-1.0 (Linux usbfs backend), exactly as it would talk to hardware.
//
// How it works. A test binary runs under `umockdev-wrapper` (the preload library that redirects
// /sys and /dev into a temporary testbed). UsbTestbed creates that testbed; every
// EmulatedUsbDevice adds a sysfs USB device (its `descriptors` attribute, busnum/devnum,
// idVendor/idProduct) and attaches an ioctl handler to its /dev/bus/usb/BBB/DDD node. libusb
// opens the node and sends USBDEVFS_* ioctls; the handler (on umockdev's worker thread) answers
// them as the device would:
//   GET_CAPABILITIES, CLAIMINTERFACE, RELEASEINTERFACE, SETINTERFACE, CLEAR_HALT, RESET(EP),
//   GETDRIVER (no kernel driver bound), SUBMITURB / REAPURB(NDELAY) / DISCARDURB for control,
//   interrupt and bulk URBs.
// Control transfers go to the test's ControlHandler (stall = EPIPE); OUT packets to its
// OutHandler; IN URBs are completed from a queue of IN packets per endpoint, which the test fills
// with queue_in() or with a producer running at a fixed rate in emulated device time
// (start_in_stream). unplug() makes every ioctl fail with ENODEV (libusb then completes all
// transfers with LIBUSB_TRANSFER_NO_DEVICE), sends the "remove" uevent (libusb's hotplug
// callback fires) and removes the sysfs device; plug() adds it again with a new device number
// (a new node: handles opened before the unplug stay dead, and get their URBs back, as in Linux).
//
// Usage (inside a GoogleTest test; skip when !UsbTestbed::in_mock_environment()):
//   palp::usbemu::UsbTestbed testbed;                        // before libusb_init
//   palp::usbemu::EmulatedUsbDevice dev(testbed, spec);      // spec: VID:PID, interfaces, EPs
//   dev.on_control([](const ControlRequest& r) { return ControlReply::in({...}); });
//   dev.on_out([](std::uint8_t ep, const std::vector<std::uint8_t>& pkt) { ... });
//   dev.start_in_stream(0x81, 1000.0, [](std::uint64_t i, std::int64_t t_ns) { return pkt; });
//   dev.plug();
//   ... libusb / palp::usb code under test ...
//   dev.unplug(); dev.plug();
// Handlers run on umockdev's worker thread (or the stream thread for producers) with no emulator
// lock held; they may call queue_in(). Everything here is test code: it allocates and locks.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

// Opaque umockdev types (GObject); the header needs neither GLib nor umockdev.
struct _UMockdevTestbed;
struct _UMockdevIoctlBase;
struct _UMockdevIoctlClient;
struct _UMockdevIoctlData;

namespace palp::usbemu {

struct EndpointSpec {
  std::uint8_t address = 0x81;     // bit 7 set: IN
  std::uint8_t attributes = 0x03;  // 2 bulk, 3 interrupt
  std::uint16_t max_packet = 64;
  std::uint8_t interval = 1;  // frames (full speed: 1 ms)
};

struct InterfaceSpec {
  std::uint8_t number = 0;
  std::uint8_t interface_class = 0xff;  // vendor specific; 3 = HID
  std::uint8_t subclass = 0;
  std::uint8_t protocol = 0;
  std::vector<std::uint8_t> class_descriptor;  // e.g. a HID descriptor, placed before the EPs
  std::vector<EndpointSpec> endpoints;
};

struct DeviceSpec {
  std::uint16_t vendor_id = 0x1209;
  std::uint16_t product_id = 0x0001;
  std::uint16_t bcd_device = 0x0100;
  std::uint16_t bcd_usb = 0x0200;
  std::uint8_t device_class = 0;  // per interface
  std::uint8_t max_packet0 = 64;
  std::vector<InterfaceSpec> interfaces{InterfaceSpec{}};
  int busnum = 0;  // 0: a fresh bus number per device in this process
};

// The device and configuration descriptors (what sysfs `descriptors` holds).
std::vector<std::uint8_t> descriptor_blob(const DeviceSpec& spec);

struct ControlRequest {
  std::uint8_t request_type = 0;  // bmRequestType (bit 7: IN)
  std::uint8_t request = 0;       // bRequest
  std::uint16_t value = 0, index = 0, length = 0;
  std::vector<std::uint8_t> data;  // the OUT data stage (empty for IN)
  bool is_in() const { return (request_type & 0x80) != 0; }
};

struct ControlReply {
  bool stall = false;
  std::vector<std::uint8_t> data;  // IN: the data stage (cut to wLength)
  static ControlReply ack() { return {}; }
  static ControlReply in(std::vector<std::uint8_t> bytes) { return {false, std::move(bytes)}; }
  static ControlReply stalled() { return {true, {}}; }
};

using ControlHandler = std::function<ControlReply(const ControlRequest&)>;
using OutHandler =
    std::function<void(std::uint8_t endpoint, const std::vector<std::uint8_t>& packet)>;
// Returns the packet for stream tick `index` at emulated device time `device_time_ns`
// (index × period), or nullopt to send nothing this tick.
using InProducer = std::function<std::optional<std::vector<std::uint8_t>>(
    std::uint64_t index, std::int64_t device_time_ns)>;

// The umockdev testbed: one per test, created before libusb is initialised.
class UsbTestbed {
 public:
  UsbTestbed();
  ~UsbTestbed();
  UsbTestbed(const UsbTestbed&) = delete;
  UsbTestbed& operator=(const UsbTestbed&) = delete;
  // True when running under umockdev-wrapper (LD_PRELOAD of libumockdev-preload).
  static bool in_mock_environment();
  _UMockdevTestbed* raw() const { return testbed_; }

 private:
  _UMockdevTestbed* testbed_ = nullptr;
};

class EmulatedUsbDevice {
 public:
  EmulatedUsbDevice(UsbTestbed& testbed, DeviceSpec spec);
  ~EmulatedUsbDevice();  // stops the stream, unplugs
  EmulatedUsbDevice(const EmulatedUsbDevice&) = delete;
  EmulatedUsbDevice& operator=(const EmulatedUsbDevice&) = delete;

  void on_control(ControlHandler handler);
  void on_out(OutHandler handler);

  // One IN packet for the next IN URB on `endpoint` (packets are delivered in order).
  void queue_in(std::uint8_t endpoint, std::vector<std::uint8_t> packet);
  // Calls `producer` every 1/rate_hz s on absolute deadlines (a thread) and queues its packets;
  // at most `max_queued` packets wait (older ones are dropped, as a device overwrites its
  // endpoint buffer). Replaces any running stream.
  void start_in_stream(std::uint8_t endpoint, double rate_hz, InProducer producer,
                       std::size_t max_queued = 8);
  void stop_in_stream();
  void clear_in(std::uint8_t endpoint);

  void plug();    // adds the device (new device number each time) and sends "add"
  void unplug();  // ioctls fail with ENODEV, "remove" uevent, sysfs device removed
  bool plugged() const { return plugged_.load(); }

  const DeviceSpec& spec() const { return spec_; }
  int busnum() const { return busnum_; }
  int devnum() const { return devnum_.load(); }
  std::string devnode() const;  // /dev/bus/usb/BBB/DDD

  std::uint64_t in_delivered() const { return in_delivered_.load(); }
  std::uint64_t in_dropped() const { return in_dropped_.load(); }
  std::uint64_t out_received() const { return out_received_.load(); }
  std::uint64_t control_transfers() const { return control_transfers_.load(); }
  std::uint64_t claims() const { return claims_.load(); }
  std::uint64_t plugs() const { return plugs_.load(); }

  // Internal: the ioctl dispatcher (called from the GObject signal).
  bool handle_ioctl(_UMockdevIoctlClient* client);

 private:
  struct Urb {
    std::string node;                    // the device node of the handle that submitted it
    _UMockdevIoctlData* data = nullptr;  // resolved usbdevfs_urb (a reference)
    unsigned long client_addr = 0;
    std::uint8_t type = 0, endpoint = 0;
    bool done = false;  // completed, waiting to be reaped
    int status = 0;
    int actual_length = 0;
  };
  bool alive(_UMockdevIoctlClient* client) const;  // plugged in, and the client's node is current
  bool handle_submit(_UMockdevIoctlClient* client, _UMockdevIoctlData* arg);
  bool handle_reap(_UMockdevIoctlClient* client, _UMockdevIoctlData* arg);
  bool handle_discard(_UMockdevIoctlClient* client, _UMockdevIoctlData* arg);
  std::string syspath() const;  // /devices/usbB
  void release_urbs();

  UsbTestbed& testbed_;
  DeviceSpec spec_;
  std::vector<std::uint8_t> descriptors_;
  int busnum_ = 0;
  std::atomic<int> devnum_{1};
  _UMockdevIoctlBase* handler_ = nullptr;
  std::vector<std::string> attached_nodes_;

  std::mutex mutex_;  // everything below
  ControlHandler control_handler_;
  OutHandler out_handler_;
  std::map<std::uint8_t, std::deque<std::vector<std::uint8_t>>> in_queues_;
  std::map<std::uint8_t, std::size_t> in_limits_;
  std::deque<Urb> urbs_;

  std::atomic<bool> plugged_{false};
  std::atomic<std::uint64_t> in_delivered_{0}, in_dropped_{0}, out_received_{0},
      control_transfers_{0}, claims_{0}, plugs_{0};

  std::thread stream_thread_;
  std::atomic<bool> stream_stop_{false};
};

// Polls `condition` every millisecond until it holds or `timeout_s` passes (tests only).
bool wait_until(const std::function<bool()>& condition, double timeout_s);

}  // namespace palp::usbemu
