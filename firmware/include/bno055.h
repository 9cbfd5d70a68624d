// Bosch BNO055 over I²C: just what the MimuCap node needs (NDOF fusion, one burst read).
//
// Register map and scale factors from the Bosch BNO055 datasheet (BST-BNO055-DS000, sections
// 3.6 "Output data" and 4.3 "Register description"). With UNIT_SEL = 0x02: acceleration in
// m/s² (100 LSB per m/s²), angular rate in rad/s (900 LSB per rad/s), magnetic field in µT
// (16 LSB per µT), quaternion unit-less (2^14 LSB per 1), all in the sensor frame of the chip
// (axis map P1, the datasheet's default: x and y as printed on most breakout boards, z out of
// the top face). In NDOF mode the chip fuses all three at 100 Hz; its quaternion is
// q_world_from_sensor, scalar first, world = east, north, up (docs/protocols.md).
#ifndef MIMUCAP_BNO055_H
#define MIMUCAP_BNO055_H

#include <Arduino.h>
#include <Wire.h>

namespace bno055 {

const uint8_t kAddressLow = 0x28;    // ADR pin low (Adafruit board default)
const uint8_t kAddressHigh = 0x29;   // ADR pin high
const uint8_t kChipIdValue = 0xA0;

enum Register : uint8_t {
  CHIP_ID = 0x00,
  PAGE_ID = 0x07,
  ACC_DATA_X_LSB = 0x08,   // first of the burst: acc 6, mag 6, gyr 6, euler 6, quaternion 8 bytes
  QUA_DATA_W_LSB = 0x20,
  CALIB_STAT = 0x35,
  SYS_STATUS = 0x39,
  UNIT_SEL = 0x3B,
  OPR_MODE = 0x3D,
  PWR_MODE = 0x3E,
  SYS_TRIGGER = 0x3F,
};

const uint8_t kModeConfig = 0x00;
const uint8_t kModeNdof = 0x0C;
const uint8_t kUnitsRadPerS = 0x02;   // acc m/s², gyr rad/s, Euler degrees, temperature °C
const size_t kBurstBytes = CALIB_STAT - ACC_DATA_X_LSB + 1;   // 46 bytes, acc .. calibration

struct Reading {
  float acc[3];      // m/s², specific force (reads about +9.81 along up at rest)
  float gyr[3];      // rad/s
  float mag_uT[3];   // µT
  float quat[4];     // w, x, y, z (normalised by the chip to 2^14)
  uint8_t calibration[4];  // system, gyroscope, accelerometer, magnetometer: 0..3
};

class Device {
 public:
  explicit Device(TwoWire& wire = Wire, uint8_t address = kAddressLow) : wire_(wire), address_(address) {}

  // Checks the chip, selects SI units and starts NDOF fusion; false if no BNO055 answers.
  bool begin() {
    uint8_t id = 0;
    for (int attempt = 0; attempt < 10 && id != kChipIdValue; ++attempt) {  // up to 650 ms after power-up
      if (!read(CHIP_ID, &id, 1)) id = 0;
      if (id != kChipIdValue) delay(65);
    }
    if (id != kChipIdValue) return false;
    write(OPR_MODE, kModeConfig);
    delay(25);                       // datasheet table 3-6: any mode → CONFIG takes 19 ms
    write(PAGE_ID, 0);
    write(PWR_MODE, 0x00);           // normal power
    write(UNIT_SEL, kUnitsRadPerS);
    write(SYS_TRIGGER, 0x00);        // internal oscillator
    write(OPR_MODE, kModeNdof);
    delay(10);                       // CONFIG → any fusion mode takes 7 ms
    return true;
  }

  // One burst read of every output and the calibration status (about 1.3 ms at 400 kHz).
  bool read(Reading* out) {
    uint8_t raw[kBurstBytes];
    if (!read(ACC_DATA_X_LSB, raw, sizeof raw)) return false;
    for (int i = 0; i < 3; ++i) {
      out->acc[i] = int16(raw + 2 * i) / 100.0f;
      out->mag_uT[i] = int16(raw + 6 + 2 * i) / 16.0f;
      out->gyr[i] = int16(raw + 12 + 2 * i) / 900.0f;
    }
    for (int i = 0; i < 4; ++i) out->quat[i] = int16(raw + (QUA_DATA_W_LSB - ACC_DATA_X_LSB) + 2 * i) / 16384.0f;
    uint8_t status = raw[CALIB_STAT - ACC_DATA_X_LSB];
    out->calibration[0] = (status >> 6) & 3;
    out->calibration[1] = (status >> 4) & 3;
    out->calibration[2] = (status >> 2) & 3;
    out->calibration[3] = status & 3;
    return true;
  }

 private:
  static int16_t int16(const uint8_t* p) { return int16_t(uint16_t(p[0]) | (uint16_t(p[1]) << 8)); }

  bool write(uint8_t reg, uint8_t value) {
    wire_.beginTransmission(address_);
    wire_.write(reg);
    wire_.write(value);
    return wire_.endTransmission() == 0;
  }

  bool read(uint8_t reg, uint8_t* data, size_t size) {
    wire_.beginTransmission(address_);
    wire_.write(reg);
    if (wire_.endTransmission(false) != 0) return false;
    if (wire_.requestFrom(address_, uint8_t(size)) != size) return false;
    for (size_t i = 0; i < size; ++i) data[i] = uint8_t(wire_.read());
    return true;
  }

  TwoWire& wire_;
  uint8_t address_;
};

}  // namespace bno055

#endif  // MIMUCAP_BNO055_H
