// Host program for tests/firmware/test_protocol_header.py: runs the firmware's protocol header
// (firmware/include/mimucap_protocol.h) on test vectors read from standard input, one per line:
//
//   U sensor seq time_us mask f0 .. f13 c0 c1 c2 c3   a sample; mask bit i = channel i present
//                                                     (acc, gyr, mag, quat, calibration, battery);
//                                                     f = acc[3] gyr[3] mag[3] quat[4] battery as
//                                                     IEEE-754 float bit patterns in hex
//   S sensor request t1 t2 t3                         a time-sync response
//   R hex                                             a time-sync request to decode
//   H sensor time_us mac                              a hello (mac: 12 hex digits)
//   Q hex                                             a hello request to decode
//
// and prints one line per vector: "U <packet hex> <line hex or ->", "S <packet hex>",
// "R ok <target> <request> <t1>" or "R bad", "H <packet hex> <line hex>", "Q ok <target>" or "Q bad".
#include <cstdint>
#include <cstring>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "mimucap_protocol.h"

static std::string hex(const uint8_t* data, size_t size) {
  static const char digits[] = "0123456789abcdef";
  std::string out;
  for (size_t i = 0; i < size; ++i) {
    out += digits[data[i] >> 4];
    out += digits[data[i] & 15];
  }
  return out;
}

static float from_bits(const std::string& text) {
  uint32_t bits = uint32_t(std::stoul(text, nullptr, 16));
  float value;
  std::memcpy(&value, &bits, 4);
  return value;
}

int main() {
  std::string line;
  while (std::getline(std::cin, line)) {
    std::istringstream in(line);
    std::string kind;
    in >> kind;
    if (kind == "U") {
      mimucap::Sample s;
      unsigned long long sensor, seq, time_us, mask;
      in >> sensor >> seq >> time_us >> mask;
      s.sensor_id = uint16_t(sensor);
      s.seq = uint32_t(seq);
      s.time_us = time_us;
      std::string f[14];
      for (auto& text : f) in >> text;
      unsigned c[4];
      for (auto& v : c) in >> v;
      s.has_acc = mask & 1; s.has_gyr = mask & 2; s.has_mag = mask & 4;
      s.has_quat = mask & 8; s.has_calibration = mask & 16; s.has_battery = mask & 32;
      for (int i = 0; i < 3; ++i) {
        s.acc[i] = from_bits(f[i]);
        s.gyr[i] = from_bits(f[3 + i]);
        s.mag_uT[i] = from_bits(f[6 + i]);
      }
      for (int i = 0; i < 4; ++i) s.quat[i] = from_bits(f[9 + i]);
      s.battery_pct = from_bits(f[13]);
      for (int i = 0; i < 4; ++i) s.calibration[i] = uint8_t(c[i]);
      uint8_t packet[mimucap::kMaxPacketBytes];
      size_t n = mimucap::encode_sample(s, packet);
      char text[mimucap::kMaxLineBytes + 8];
      size_t m = mimucap::encode_line(s, text, sizeof text);
      std::cout << "U " << hex(packet, n) << " " << (m ? hex(reinterpret_cast<uint8_t*>(text), m) : "-") << "\n";
    } else if (kind == "S") {
      unsigned long long sensor, request, t1, t2, t3;
      in >> sensor >> request >> t1 >> t2 >> t3;
      uint8_t packet[64];
      size_t n = mimucap::encode_sync_response(uint16_t(sensor), uint32_t(request), t1, t2, t3, packet);
      std::cout << "S " << hex(packet, n) << "\n";
    } else if (kind == "H") {
      unsigned long long sensor, time_us;
      std::string mac_text;
      in >> sensor >> time_us >> mac_text;
      uint8_t mac[mimucap::kMacBytes];
      for (size_t i = 0; i < mimucap::kMacBytes; ++i) mac[i] = uint8_t(std::stoul(mac_text.substr(2 * i, 2), nullptr, 16));
      uint8_t packet[64];
      size_t n = mimucap::encode_hello(uint16_t(sensor), time_us, mac, packet);
      char text[64];
      size_t m = mimucap::encode_hello_line(uint16_t(sensor), mac, text, sizeof text);
      std::cout << "H " << hex(packet, n) << " " << (m ? hex(reinterpret_cast<uint8_t*>(text), m) : "-") << "\n";
    } else if (kind == "Q") {
      std::string text;
      in >> text;
      std::vector<uint8_t> bytes;
      for (size_t i = 0; i + 1 < text.size(); i += 2) bytes.push_back(uint8_t(std::stoul(text.substr(i, 2), nullptr, 16)));
      uint16_t target = 0;
      if (mimucap::decode_hello_request(bytes.data(), bytes.size(), &target)) {
        std::cout << "Q ok " << target << "\n";
      } else {
        std::cout << "Q bad\n";
      }
    } else if (kind == "R") {
      std::string text;
      in >> text;
      std::vector<uint8_t> bytes;
      for (size_t i = 0; i + 1 < text.size(); i += 2) bytes.push_back(uint8_t(std::stoul(text.substr(i, 2), nullptr, 16)));
      mimucap::SyncRequest request;
      if (mimucap::decode_sync_request(bytes.data(), bytes.size(), &request)) {
        std::cout << "R ok " << request.target_id << " " << request.request_id << " " << request.host_send_us << "\n";
      } else {
        std::cout << "R bad\n";
      }
    }
  }
  return 0;
}
