// MimuCap device protocols, node side: the UDP packet (protocol v1), its hello, and the serial line.
//
// The reference implementation of docs/protocols.md for sensor nodes. Portable C++11 with no
// Arduino dependency: the firmware (src/main.cpp) includes it, and the host test
// (tests/firmware/test_protocol_header.py) compiles it with the system's g++ and checks its
// bytes against the Python encoder of app/mimucap/acquisition/protocol_udp.py and
// protocol_serial.py.
//
// Units (docs/protocols.md, shared conventions): acc m/s² (specific force), gyr rad/s, mag µT,
// all in the sensor frame; q_world_from_sensor scalar first [w, x, y, z], world ENU;
// calibration status 0..3 each (BNO055: system, gyroscope, accelerometer, magnetometer);
// battery percent; time_us the node clock in µs; seq the node's sample counter (wraps at 2^32).
//
// Values are written as they are: a NaN or infinity is sent and the host refuses that sample
// with a reason (non_finite), keeping its sequence number, so the gap is not counted as a loss.
// A battery value that is not a number is sent as 255 over UDP (refused as out_of_range).
#ifndef MIMUCAP_PROTOCOL_H
#define MIMUCAP_PROTOCOL_H

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>

namespace mimucap {

const uint16_t kMagic = 0x434D;            // bytes "MC"
const uint8_t kVersion = 1;
const uint8_t kTypeSample = 1;
const uint8_t kTypeSyncRequest = 2;
const uint8_t kTypeSyncResponse = 3;
const uint8_t kTypeHello = 4;             // node → host: the node's factory MAC
const uint8_t kTypeHelloRequest = 5;      // host → node: "say hello"
const uint16_t kBroadcastId = 0xFFFF;
const size_t kMacBytes = 6;
const size_t kHeaderBytes = 20;
const size_t kCrcBytes = 4;
const size_t kMaxPacketBytes = 256;
const size_t kMaxLineBytes = 256;          // without "\r\n"

enum Flag : uint16_t {
  kFlagAcc = 1u << 0,
  kFlagGyr = 1u << 1,
  kFlagMag = 1u << 2,
  kFlagQuat = 1u << 3,
  kFlagCalibration = 1u << 4,
  kFlagBattery = 1u << 5,
};

// One measurement of one sensor; a channel is sent only when its has_* is true.
struct Sample {
  uint16_t sensor_id = 0;
  uint32_t seq = 0;
  uint64_t time_us = 0;
  bool has_acc = false, has_gyr = false, has_mag = false, has_quat = false;
  bool has_calibration = false, has_battery = false;
  float acc[3] = {0, 0, 0};     // m/s²
  float gyr[3] = {0, 0, 0};     // rad/s
  float mag_uT[3] = {0, 0, 0};  // µT
  float quat[4] = {1, 0, 0, 0};  // q_world_from_sensor, w x y z
  uint8_t calibration[4] = {0, 0, 0, 0};  // system, gyr, acc, mag: 0..3
  float battery_pct = 0;        // 0..100
};

struct SyncRequest {
  uint16_t target_id;   // this node's id, or kBroadcastId
  uint32_t request_id;
  uint64_t host_send_us;  // t1, host clock
};

// CRC-32 (IEEE 802.3, zlib's crc32) of `size` bytes, four bits at a time (16-entry table:
// small enough for any microcontroller, fast enough for 100 packets a second).
inline uint32_t crc32(const uint8_t* data, size_t size) {
  static const uint32_t table[16] = {
      0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu, 0x76DC4190u, 0x6B6B51F4u,
      0x4DB26158u, 0x5005713Cu, 0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu,
      0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu};
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t i = 0; i < size; ++i) {
    crc ^= data[i];
    crc = (crc >> 4) ^ table[crc & 0x0F];
    crc = (crc >> 4) ^ table[crc & 0x0F];
  }
  return crc ^ 0xFFFFFFFFu;
}

namespace detail {

// Little-endian writers, independent of the machine's byte order.
inline uint8_t* put_u8(uint8_t* p, uint8_t v) { *p = v; return p + 1; }
inline uint8_t* put_u16(uint8_t* p, uint16_t v) {
  p[0] = uint8_t(v); p[1] = uint8_t(v >> 8);
  return p + 2;
}
inline uint8_t* put_u32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = uint8_t(v >> (8 * i));
  return p + 4;
}
inline uint8_t* put_u64(uint8_t* p, uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = uint8_t(v >> (8 * i));
  return p + 8;
}
inline uint8_t* put_f32(uint8_t* p, float v) {
  uint32_t bits;
  std::memcpy(&bits, &v, 4);
  return put_u32(p, bits);
}
inline uint16_t get_u16(const uint8_t* p) { return uint16_t(p[0] | (p[1] << 8)); }
inline uint32_t get_u32(const uint8_t* p) {
  return uint32_t(p[0]) | (uint32_t(p[1]) << 8) | (uint32_t(p[2]) << 16) | (uint32_t(p[3]) << 24);
}
inline uint64_t get_u64(const uint8_t* p) { return uint64_t(get_u32(p)) | (uint64_t(get_u32(p + 4)) << 32); }

inline uint8_t* put_header(uint8_t* p, uint8_t type, uint16_t sensor_id, uint16_t flags, uint32_t seq,
                           uint64_t time_us) {
  p = put_u16(p, kMagic);
  p = put_u8(p, kVersion);
  p = put_u8(p, type);
  p = put_u16(p, sensor_id);
  p = put_u16(p, flags);
  p = put_u32(p, seq);
  return put_u64(p, time_us);
}

inline size_t finish(uint8_t* start, uint8_t* end) {
  uint32_t crc = crc32(start, size_t(end - start));
  end = put_u32(end, crc);
  return size_t(end - start);
}

// Battery percent as one byte: rounded half to even (as Python's round), clamped to 0..255;
// NaN becomes 255, which the host refuses as out of range.
inline uint8_t battery_byte(float pct) {
  if (std::isnan(pct)) return 255;
  double rounded = std::nearbyint(double(pct));
  if (rounded < 0) return 0;
  if (rounded > 255) return 255;
  return uint8_t(rounded);
}

}  // namespace detail

// Bytes of the UDP packet of `sample` written to `out` (at least kMaxPacketBytes long);
// returns the packet length.
inline size_t encode_sample(const Sample& s, uint8_t* out) {
  uint16_t flags = 0;
  if (s.has_acc) flags |= kFlagAcc;
  if (s.has_gyr) flags |= kFlagGyr;
  if (s.has_mag) flags |= kFlagMag;
  if (s.has_quat) flags |= kFlagQuat;
  if (s.has_calibration) flags |= kFlagCalibration;
  if (s.has_battery) flags |= kFlagBattery;
  uint8_t* p = detail::put_header(out, kTypeSample, s.sensor_id, flags, s.seq, s.time_us);
  if (s.has_acc) for (int i = 0; i < 3; ++i) p = detail::put_f32(p, s.acc[i]);
  if (s.has_gyr) for (int i = 0; i < 3; ++i) p = detail::put_f32(p, s.gyr[i]);
  if (s.has_mag) for (int i = 0; i < 3; ++i) p = detail::put_f32(p, s.mag_uT[i]);
  if (s.has_quat) for (int i = 0; i < 4; ++i) p = detail::put_f32(p, s.quat[i]);
  if (s.has_calibration) {
    const uint8_t* c = s.calibration;
    p = detail::put_u8(p, uint8_t((c[0] & 3) << 6 | (c[1] & 3) << 4 | (c[2] & 3) << 2 | (c[3] & 3)));
  }
  if (s.has_battery) p = detail::put_u8(p, detail::battery_byte(s.battery_pct));
  return detail::finish(out, p);
}

// The answer to a time-sync request: t1 echoed, t2 = node clock when the request arrived,
// t3 = node clock now (µs). `out` holds at least 40 bytes; returns the length (40).
inline size_t encode_sync_response(uint16_t sensor_id, uint32_t request_id, uint64_t host_send_us,
                                   uint64_t node_receive_us, uint64_t node_send_us, uint8_t* out) {
  uint8_t* p = detail::put_header(out, kTypeSyncResponse, sensor_id, 0, request_id, node_receive_us);
  p = detail::put_u64(p, host_send_us);
  p = detail::put_u64(p, node_send_us);
  return detail::finish(out, p);
}

// Reads a host → node time-sync request; false for anything else (wrong magic, version, type,
// length or checksum).
inline bool decode_sync_request(const uint8_t* data, size_t size, SyncRequest* request) {
  if (size != kHeaderBytes + kCrcBytes) return false;
  if (detail::get_u16(data) != kMagic || data[2] != kVersion || data[3] != kTypeSyncRequest) return false;
  if (detail::get_u16(data + 6) != 0) return false;
  if (crc32(data, kHeaderBytes) != detail::get_u32(data + kHeaderBytes)) return false;
  request->target_id = detail::get_u16(data + 4);
  request->request_id = detail::get_u32(data + 8);
  request->host_send_us = detail::get_u64(data + 12);
  return true;
}

// The hello packet: which hardware sends under `sensor_id` (its factory MAC, 6 bytes), with the
// node clock `time_us`. `out` holds at least 30 bytes; returns the length (30).
inline size_t encode_hello(uint16_t sensor_id, uint64_t time_us, const uint8_t mac[kMacBytes], uint8_t* out) {
  uint8_t* p = detail::put_header(out, kTypeHello, sensor_id, 0, 0, time_us);
  std::memcpy(p, mac, kMacBytes);
  return detail::finish(out, p + kMacBytes);
}

// Reads a host → node hello request; false for anything else. `target_id` is this node's id or
// kBroadcastId.
inline bool decode_hello_request(const uint8_t* data, size_t size, uint16_t* target_id) {
  if (size != kHeaderBytes + kCrcBytes) return false;
  if (detail::get_u16(data) != kMagic || data[2] != kVersion || data[3] != kTypeHelloRequest) return false;
  if (detail::get_u16(data + 6) != 0) return false;
  if (crc32(data, kHeaderBytes) != detail::get_u32(data + kHeaderBytes)) return false;
  *target_id = detail::get_u16(data + 4);
  return true;
}

namespace detail {

// Appends printf output to the line; false when it no longer fits.
struct LineWriter {
  char* out;
  size_t capacity;
  size_t length;
  bool ok;

  void text(const char* s) {
    size_t n = std::strlen(s);
    if (!ok || length + n >= capacity) { ok = false; return; }
    std::memcpy(out + length, s, n + 1);
    length += n;
  }
  // A number as Python's format(value, ".7g"): seven significant digits; NaN is "nan" (C may
  // print "-nan"), infinities "inf" and "-inf".
  void number(float value) {
    char buffer[32];
    if (std::isnan(value)) {
      text(",nan");
      return;
    }
    std::snprintf(buffer, sizeof buffer, ",%.7g", double(value));
    text(buffer);
  }
  void integer(unsigned long long value) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%llu", value);
    text(buffer);
  }
  // Closes the line with its checksum (XOR of every byte after the "$") and "*HH\r\n";
  // returns its length, or 0 if anything did not fit.
  size_t finish() {
    if (!ok) return 0;
    uint8_t checksum = 0;
    for (size_t i = 1; i < length; ++i) checksum ^= uint8_t(out[i]);
    char tail[8];
    std::snprintf(tail, sizeof tail, "*%02X\r\n", checksum);
    text(tail);
    return ok ? length : 0;
  }
};

}  // namespace detail

// The serial line of `sample` ("$MIMU,...*HH\r\n") written to `out` (NUL-terminated, at least
// kMaxLineBytes + 3 long); returns its length without the NUL, or 0 if it would exceed the
// protocol's line length.
inline size_t encode_line(const Sample& s, char* out, size_t capacity) {
  detail::LineWriter w{out, capacity, 0, true};
  out[0] = '\0';
  w.text("$MIMU,");
  w.integer(s.sensor_id);
  w.text(",");
  w.integer(s.seq);
  w.text(",");
  w.integer(s.time_us);
  if (s.has_acc) { w.text(",A"); for (int i = 0; i < 3; ++i) w.number(s.acc[i]); }
  if (s.has_gyr) { w.text(",G"); for (int i = 0; i < 3; ++i) w.number(s.gyr[i]); }
  if (s.has_mag) { w.text(",M"); for (int i = 0; i < 3; ++i) w.number(s.mag_uT[i]); }
  if (s.has_quat) { w.text(",Q"); for (int i = 0; i < 4; ++i) w.number(s.quat[i]); }
  if (s.has_calibration) {
    w.text(",C");
    for (int i = 0; i < 4; ++i) {
      w.text(",");
      w.integer(s.calibration[i]);
    }
  }
  if (s.has_battery) { w.text(",B"); w.number(s.battery_pct); }
  if (!w.ok || w.length > kMaxLineBytes - 3) return 0;
  return w.finish();
}

// The serial hello line ("$MIMUH,<sensor_id>,<MAC as 12 hex digits>*HH\r\n") written to `out`
// (NUL-terminated, at least 40 bytes); returns its length without the NUL.
inline size_t encode_hello_line(uint16_t sensor_id, const uint8_t mac[kMacBytes], char* out, size_t capacity) {
  detail::LineWriter w{out, capacity, 0, true};
  out[0] = '\0';
  w.text("$MIMUH,");
  w.integer(sensor_id);
  char hex[2 * kMacBytes + 2];
  std::snprintf(hex, sizeof hex, ",%02X%02X%02X%02X%02X%02X", mac[0], mac[1], mac[2], mac[3], mac[4], mac[5]);
  w.text(hex);
  return w.finish();
}

}  // namespace mimucap

#endif  // MIMUCAP_PROTOCOL_H
