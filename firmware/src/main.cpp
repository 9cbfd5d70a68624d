// MimuCap sensor node: ESP32 + Bosch BNO055, the reference implementation of the node side of
// docs/protocols.md (UDP protocol v1 with its hello, and the serial line protocol).
//
// * A hardware timer ticks at 100 Hz; its interrupt stamps the node clock (esp_timer_get_time,
//   µs since boot) and wakes the sampling task, which reads the BNO055 in one I²C burst (raw
//   acceleration, angular rate and magnetic field in SI units, the fused quaternion and the
//   calibration status), numbers the sample (seq, wraps at 2^32; a failed read leaves its
//   number unused, which the host counts as a drop) and sends it by UDP and/or USB serial.
// * The host's time-sync requests are answered with the node clock (t2 on arrival, t3 when
//   answering), so the host maps the node clock onto its own.
// * The sensor id is the low 16 bits of the chip's factory MAC (0xFFFF, the broadcast id,
//   becomes 0xFFFE): stable for a board, printed by "show".
// * The hello says which board this is: its whole factory MAC, the device id its magnetometer
//   calibration is kept for on the host. Sent over UDP when Wi-Fi connects and whenever the host
//   asks (hello request), and over the serial output every second (that link is one-way).
// * Wi-Fi, host address, output and battery measurement are set over the USB serial console
//   and kept in flash (NVS, Preferences "mimucap"): no recompiling per board or network.
//   Console replies start with "#", so a host reading the serial protocol refuses them as
//   malformed lines (counted) instead of taking them for samples.
//
// Console commands (115200 baud, one per line):
//   show                         settings, sensor id, Wi-Fi state, BNO055 calibration
//   wifi <ssid> [password]       join this network (restart to apply)
//   host <ip> [port]             the MimuCap host (default port 5555)
//   output udp|serial|both       where samples go (default udp)
//   battery <gpio> <divider>     measure the battery on this ADC1 pin (GPIO 32-39) behind a
//                                divider of this ratio (e.g. 35 2.0); "battery off" sends no
//                                battery channel
//   restart
#include <Arduino.h>
#include <Preferences.h>
#include <WiFi.h>
#include <WiFiUdp.h>
#include <Wire.h>
#include <esp_timer.h>
#if ESP_ARDUINO_VERSION_MAJOR >= 3
#include <esp_mac.h>
#else
#include <esp_system.h>
#endif

#include "bno055.h"
#include "mimucap_protocol.h"

namespace {

const uint32_t kSamplePeriodUs = 10000;  // 100 Hz
const uint16_t kDefaultPort = 5555;
const uint32_t kBatteryPeriodMs = 2000;
const uint32_t kSerialHelloPeriodMs = 1000;

struct Settings {
  String ssid, password, host;
  uint16_t port = kDefaultPort;
  bool udp = true, serial = false;
  int battery_pin = -1;        // -1: not measured
  float battery_divider = 2.0f;
};

Settings settings;
Preferences preferences;
WiFiUDP udp;                  // samples out, time-sync requests in: one socket, one port
SemaphoreHandle_t udp_lock;   // the sampling task and the loop task both use it
IPAddress host_ip;
bool host_valid = false;
bno055::Device imu;
bool imu_ok = false;
uint16_t sensor_id = 0;
uint8_t node_mac[mimucap::kMacBytes];   // the factory MAC: the device id its hello carries
uint32_t next_seq = 0;
float battery_pct = NAN;

hw_timer_t* sample_timer = nullptr;
TaskHandle_t sampling_task = nullptr;
volatile uint64_t tick_time_us = 0;   // node clock at the last timer tick
portMUX_TYPE tick_lock = portMUX_INITIALIZER_UNLOCKED;

void IRAM_ATTR on_tick() {
  tick_time_us = uint64_t(esp_timer_get_time());
  BaseType_t woken = pdFALSE;
  vTaskNotifyGiveFromISR(sampling_task, &woken);
  if (woken) portYIELD_FROM_ISR();
}

void load_settings() {
  preferences.begin("mimucap", true);
  settings.ssid = preferences.getString("ssid", "");
  settings.password = preferences.getString("password", "");
  settings.host = preferences.getString("host", "");
  settings.port = preferences.getUShort("port", kDefaultPort);
  settings.udp = preferences.getBool("udp", true);
  settings.serial = preferences.getBool("serial", false);
  settings.battery_pin = preferences.getInt("battery_pin", -1);
  settings.battery_divider = preferences.getFloat("battery_div", 2.0f);
  preferences.end();
  host_valid = host_ip.fromString(settings.host);
}

void save_settings() {
  preferences.begin("mimucap", false);
  preferences.putString("ssid", settings.ssid);
  preferences.putString("password", settings.password);
  preferences.putString("host", settings.host);
  preferences.putUShort("port", settings.port);
  preferences.putBool("udp", settings.udp);
  preferences.putBool("serial", settings.serial);
  preferences.putInt("battery_pin", settings.battery_pin);
  preferences.putFloat("battery_div", settings.battery_divider);
  preferences.end();
  host_valid = host_ip.fromString(settings.host);
}

uint16_t id_from_mac() {
  uint16_t id = uint16_t(node_mac[4]) << 8 | node_mac[5];
  return id == mimucap::kBroadcastId ? uint16_t(0xFFFE) : id;
}

// The hello packet to `ip`:`port` (the host; the caller holds udp_lock).
void send_hello_locked(IPAddress ip, uint16_t port) {
  uint8_t packet[64];
  size_t n = mimucap::encode_hello(sensor_id, uint64_t(esp_timer_get_time()), node_mac, packet);
  udp.beginPacket(ip, port);
  udp.write(packet, n);
  udp.endPacket();
}

void send_serial_hello() {
  char line[64];
  size_t n = mimucap::encode_hello_line(sensor_id, node_mac, line, sizeof line);
  if (n) Serial.write(reinterpret_cast<const uint8_t*>(line), n);
}

// Remaining charge of a single Li-ion/LiPo cell from its resting voltage (piecewise linear
// through typical discharge-curve points; about ±10 % under load).
float battery_percent(float volts) {
  static const float curve[][2] = {{3.30f, 0}, {3.60f, 10}, {3.70f, 30}, {3.80f, 55},
                                   {3.95f, 75}, {4.10f, 92}, {4.20f, 100}};
  if (volts <= curve[0][0]) return 0;
  for (size_t i = 1; i < sizeof curve / sizeof curve[0]; ++i) {
    if (volts <= curve[i][0]) {
      float f = (volts - curve[i - 1][0]) / (curve[i][0] - curve[i - 1][0]);
      return curve[i - 1][1] + f * (curve[i][1] - curve[i - 1][1]);
    }
  }
  return 100;
}

void measure_battery() {
  if (settings.battery_pin < 0) {
    battery_pct = NAN;
    return;
  }
  uint32_t millivolts = analogReadMilliVolts(settings.battery_pin);  // calibrated ADC reading
  battery_pct = battery_percent(millivolts * 1e-3f * settings.battery_divider);
}

void send_sample(const mimucap::Sample& sample) {
  if (settings.udp && host_valid && WiFi.status() == WL_CONNECTED) {
    uint8_t packet[mimucap::kMaxPacketBytes];
    size_t size = mimucap::encode_sample(sample, packet);
    xSemaphoreTake(udp_lock, portMAX_DELAY);
    udp.beginPacket(host_ip, settings.port);
    udp.write(packet, size);
    udp.endPacket();
    xSemaphoreGive(udp_lock);
  }
  if (settings.serial) {
    char line[mimucap::kMaxLineBytes + 8];
    size_t size = mimucap::encode_line(sample, line, sizeof line);
    if (size) Serial.write(reinterpret_cast<const uint8_t*>(line), size);
  }
}

// The sampling task: woken by every timer tick, reads the BNO055 and sends one sample.
void sampling_loop(void*) {
  for (;;) {
    ulTaskNotifyTake(pdTRUE, portMAX_DELAY);
    portENTER_CRITICAL(&tick_lock);
    uint64_t stamp_us = tick_time_us;
    portEXIT_CRITICAL(&tick_lock);
    uint32_t seq = next_seq++;
    bno055::Reading reading;
    if (!imu_ok || !imu.read(&reading)) continue;   // the number stays unused: a counted drop
    mimucap::Sample sample;
    sample.sensor_id = sensor_id;
    sample.seq = seq;
    sample.time_us = stamp_us;
    sample.has_acc = sample.has_gyr = sample.has_mag = sample.has_quat = sample.has_calibration = true;
    memcpy(sample.acc, reading.acc, sizeof sample.acc);
    memcpy(sample.gyr, reading.gyr, sizeof sample.gyr);
    memcpy(sample.mag_uT, reading.mag_uT, sizeof sample.mag_uT);
    memcpy(sample.quat, reading.quat, sizeof sample.quat);
    memcpy(sample.calibration, reading.calibration, sizeof sample.calibration);
    sample.has_battery = !isnan(battery_pct);
    sample.battery_pct = battery_pct;
    send_sample(sample);
  }
}

void start_timer() {
#if ESP_ARDUINO_VERSION_MAJOR >= 3
  sample_timer = timerBegin(1000000);                 // 1 MHz: one count per µs
  timerAttachInterrupt(sample_timer, &on_tick);
  timerAlarm(sample_timer, kSamplePeriodUs, true, 0);
#else
  sample_timer = timerBegin(0, 80, true);             // 80 MHz APB / 80: one count per µs
  timerAttachInterrupt(sample_timer, &on_tick, true);
  timerAlarmWrite(sample_timer, kSamplePeriodUs, true);
  timerAlarmEnable(sample_timer);
#endif
}

// Answers the host's time-sync and hello requests (and ignores anything else on the port). The
// host sends them to the address the samples come from.
void serve_requests() {
  xSemaphoreTake(udp_lock, portMAX_DELAY);
  int size = udp.parsePacket();
  while (size > 0) {
    uint64_t received_us = uint64_t(esp_timer_get_time());
    uint8_t data[mimucap::kMaxPacketBytes];
    int length = udp.read(data, sizeof data);
    mimucap::SyncRequest request;
    uint16_t hello_target = 0;
    if (length > 0 && mimucap::decode_sync_request(data, size_t(length), &request) &&
        (request.target_id == sensor_id || request.target_id == mimucap::kBroadcastId)) {
      uint8_t answer[64];
      size_t n = mimucap::encode_sync_response(sensor_id, request.request_id, request.host_send_us, received_us,
                                               uint64_t(esp_timer_get_time()), answer);
      udp.beginPacket(udp.remoteIP(), udp.remotePort());
      udp.write(answer, n);
      udp.endPacket();
    } else if (length > 0 && mimucap::decode_hello_request(data, size_t(length), &hello_target) &&
               (hello_target == sensor_id || hello_target == mimucap::kBroadcastId)) {
      send_hello_locked(udp.remoteIP(), udp.remotePort());
    }
    size = udp.parsePacket();
  }
  xSemaphoreGive(udp_lock);
}

void show() {
  Serial.printf("# MimuCap node, sensor id %u (from the MAC), protocol v%u\r\n", sensor_id, mimucap::kVersion);
  Serial.printf("# device mac:%02X%02X%02X%02X%02X%02X (said in its hello)\r\n", node_mac[0], node_mac[1], node_mac[2],
                node_mac[3], node_mac[4], node_mac[5]);
  Serial.printf("# BNO055: %s\r\n", imu_ok ? "found, NDOF fusion at 100 Hz" : "NOT FOUND (check wiring)");
  Serial.printf("# wifi '%s' (%s), IP %s\r\n", settings.ssid.c_str(),
                WiFi.status() == WL_CONNECTED ? "connected" : "not connected", WiFi.localIP().toString().c_str());
  Serial.printf("# host %s port %u, output %s%s%s\r\n", settings.host.length() ? settings.host.c_str() : "(not set)",
                settings.port, settings.udp ? "udp " : "", settings.serial ? "serial" : "",
                settings.udp || settings.serial ? "" : "nothing");
  if (settings.battery_pin >= 0) {
    Serial.printf("# battery on GPIO %d, divider %.2f: %.0f %%\r\n", settings.battery_pin, settings.battery_divider,
                  battery_pct);
  } else {
    Serial.printf("# battery not measured\r\n");
  }
  bno055::Reading reading;
  if (imu_ok && imu.read(&reading)) {
    Serial.printf("# calibration system %u gyr %u acc %u mag %u (3 = calibrated)\r\n", reading.calibration[0],
                  reading.calibration[1], reading.calibration[2], reading.calibration[3]);
  }
}

void command(String line) {
  line.trim();
  int space = line.indexOf(' ');
  String verb = space < 0 ? line : line.substring(0, space);
  String rest = space < 0 ? String() : line.substring(space + 1);
  rest.trim();
  int split = rest.indexOf(' ');
  String first = split < 0 ? rest : rest.substring(0, split);
  String second = split < 0 ? String() : rest.substring(split + 1);
  if (verb == "show") {
    show();
  } else if (verb == "wifi" && first.length()) {
    settings.ssid = first;
    settings.password = second;
    save_settings();
    Serial.printf("# wifi saved; 'restart' to join '%s'\r\n", first.c_str());
  } else if (verb == "host" && first.length()) {
    IPAddress probe;
    if (!probe.fromString(first)) {
      Serial.printf("# not an IP address: %s\r\n", first.c_str());
      return;
    }
    long port = second.length() ? second.toInt() : kDefaultPort;
    if (port < 1 || port > 65535) {
      Serial.printf("# bad port %s (1..65535)\r\n", second.c_str());
      return;
    }
    settings.host = first;
    settings.port = uint16_t(port);
    save_settings();
    Serial.printf("# host %s port %u saved\r\n", first.c_str(), settings.port);
  } else if (verb == "output" && (first == "udp" || first == "serial" || first == "both")) {
    settings.udp = first != "serial";
    settings.serial = first != "udp";
    save_settings();
    Serial.printf("# output %s saved\r\n", first.c_str());
  } else if (verb == "battery" && first == "off") {
    settings.battery_pin = -1;
    save_settings();
    measure_battery();
    Serial.printf("# battery not measured\r\n");
  } else if (verb == "battery" && first.length() && second.length()) {
    long pin = first.toInt();
    float divider = second.toFloat();
    // ADC1 pins only (GPIO 32-39): ADC2 cannot be read while Wi-Fi is on
    if (pin < 32 || pin > 39 || !(divider >= 1.0f && divider <= 20.0f)) {
      Serial.printf("# battery <gpio 32..39 (ADC1)> <divider 1..20>, e.g. battery 35 2.0\r\n");
      return;
    }
    settings.battery_pin = int(pin);
    settings.battery_divider = divider;
    save_settings();
    measure_battery();
    Serial.printf("# battery on GPIO %ld, divider %.2f saved\r\n", pin, divider);
  } else if (verb == "restart") {
    ESP.restart();
  } else if (verb.length()) {
    Serial.printf("# commands: show | wifi <ssid> [password] | host <ip> [port] | output udp|serial|both | "
                  "battery <gpio> <divider> | battery off | restart\r\n");
  }
}

String console_line;

void read_console() {
  while (Serial.available()) {
    char c = char(Serial.read());
    if (c == '\n' || c == '\r') {
      if (console_line.length()) command(console_line);
      console_line = "";
    } else if (console_line.length() < 160) {
      console_line += c;
    }
  }
}

}  // namespace

void setup() {
  Serial.begin(115200);
  load_settings();
  esp_efuse_mac_get_default(node_mac);
  sensor_id = id_from_mac();
  Wire.begin();               // SDA GPIO 21, SCL GPIO 22 on ESP32 DevKit boards
  Wire.setClock(400000);
  imu_ok = imu.begin();
  measure_battery();
  if (settings.ssid.length()) {
    WiFi.mode(WIFI_STA);
    WiFi.setSleep(false);     // modem sleep delays packets by up to a beacon interval (~100 ms)
    WiFi.begin(settings.ssid.c_str(), settings.password.c_str());
  }
  udp_lock = xSemaphoreCreateMutex();
  udp.begin(settings.port);   // samples leave from this port; the host's time-sync requests arrive on it
  show();
  xTaskCreatePinnedToCore(sampling_loop, "sampling", 4096, nullptr, configMAX_PRIORITIES - 2, &sampling_task, 1);
  start_timer();
}

void loop() {
  static uint32_t last_battery_ms = 0;
  static uint32_t last_serial_hello_ms = 0;
  static bool was_connected = false;
  read_console();
  bool connected = WiFi.status() == WL_CONNECTED;
  if (connected && !was_connected && settings.udp && host_valid) {   // just joined: say hello
    xSemaphoreTake(udp_lock, portMAX_DELAY);
    send_hello_locked(host_ip, settings.port);
    xSemaphoreGive(udp_lock);
  }
  was_connected = connected;
  if (connected) serve_requests();
  if (settings.serial && millis() - last_serial_hello_ms >= kSerialHelloPeriodMs) {
    last_serial_hello_ms = millis();
    send_serial_hello();
  }
  if (millis() - last_battery_ms >= kBatteryPeriodMs) {
    last_battery_ms = millis();
    measure_battery();
  }
  delay(1);   // the console and the time sync only; samples are timed by the hardware timer
}
