/* Board link protocol, version 1: encoding, decoding, CRC-32C, COBS (protocol.h). */
#include "hexa_board/protocol.h"

/* Sensor frame field offsets (docs/board_protocol.md, "Sensor frame"). */
enum {
  S_TIME = 8,
  S_ACK = 12,
  S_STATUS = 16,
  S_DIN = 18,
  S_ADC = 20,
  S_QUAT = 58,
  S_RATE = 66,
  S_IMU_COUNT = 72,
  S_LAST_REJECT = 73,
  S_DAC = 74,
  S_WATCHDOG_COUNT = 86,
  S_REJECTED = 88,
  S_WATCHDOG_MS = 90,
  S_CRC = 92
};
/* Command frame field offsets ("Command frame"). */
enum { C_FLAGS = 8, C_WATCHDOG_MS = 10, C_DAC = 12, C_CRC = 24 };

static void put16(uint8_t* p, uint16_t v) {
  p[0] = (uint8_t)(v & 0xFFu);
  p[1] = (uint8_t)(v >> 8);
}
static void put32(uint8_t* p, uint32_t v) {
  put16(p, (uint16_t)(v & 0xFFFFu));
  put16(p + 2, (uint16_t)(v >> 16));
}
static uint16_t get16(const uint8_t* p) { return (uint16_t)(p[0] | (uint16_t)(p[1] << 8)); }
static uint32_t get32(const uint8_t* p) { return (uint32_t)get16(p) | ((uint32_t)get16(p + 2) << 16); }
/* Two's complement without implementation-defined conversion. */
static int16_t get16s(const uint8_t* p) {
  const uint16_t u = get16(p);
  return u < 0x8000u ? (int16_t)u : (int16_t)(-(int32_t)(0x10000u - u));
}
static void put16s(uint8_t* p, int16_t v) { put16(p, (uint16_t)(v < 0 ? 0x10000 + (int32_t)v : v)); }

/* Nibble table of the reflected polynomial 0x82F63B78 (64 bytes of flash). */
static const uint32_t kCrcNibble[16] = {
    0x00000000u, 0x105EC76Fu, 0x20BD8EDEu, 0x30E349B1u, 0x417B1DBCu, 0x5125DAD3u,
    0x61C69362u, 0x7198540Du, 0x82F63B78u, 0x92A8FC17u, 0xA24BB5A6u, 0xB21572C9u,
    0xC38D26C4u, 0xD3D3E1ABu, 0xE330A81Au, 0xF36E6F75u};

uint32_t hb_crc32c_update(uint32_t crc, const uint8_t* data, size_t size) {
  size_t i;
  crc = ~crc;
  for (i = 0; i < size; ++i) {
    crc ^= data[i];
    crc = (crc >> 4) ^ kCrcNibble[crc & 0x0Fu];
    crc = (crc >> 4) ^ kCrcNibble[crc & 0x0Fu];
  }
  return ~crc;
}

uint32_t hb_crc32c(const uint8_t* data, size_t size) { return hb_crc32c_update(0u, data, size); }

static void put_header(uint8_t* out, uint8_t type, uint32_t sequence) {
  out[0] = HB_MAGIC_0;
  out[1] = HB_MAGIC_1;
  out[2] = HB_VERSION;
  out[3] = type;
  put32(out + 4, sequence);
}

size_t hb_encode_sensor(const hb_sensor_frame* f, uint8_t* out) {
  int i;
  put_header(out, HB_TYPE_SENSOR, f->sequence);
  put32(out + S_TIME, f->board_time_us);
  put32(out + S_ACK, f->ack_sequence);
  put16(out + S_STATUS, f->status);
  put16(out + S_DIN, f->digital_inputs);
  for (i = 0; i < HB_ADC_CHANNELS; ++i) put16(out + S_ADC + 2 * i, f->adc[i]);
  for (i = 0; i < 4; ++i) put16s(out + S_QUAT + 2 * i, f->imu_quat[i]);
  for (i = 0; i < 3; ++i) put16s(out + S_RATE + 2 * i, f->imu_rate[i]);
  out[S_IMU_COUNT] = f->imu_count;
  out[S_LAST_REJECT] = f->last_reject;
  for (i = 0; i < HB_NUM_LEGS; ++i) put16(out + S_DAC + 2 * i, f->dac_applied[i]);
  put16(out + S_WATCHDOG_COUNT, f->watchdog_count);
  put16(out + S_REJECTED, f->rejected_count);
  put16(out + S_WATCHDOG_MS, f->watchdog_ms);
  put32(out + S_CRC, hb_crc32c(out, S_CRC));
  return HB_SENSOR_FRAME_SIZE;
}

size_t hb_encode_command(const hb_command_frame* f, uint8_t* out) {
  int i;
  put_header(out, HB_TYPE_COMMAND, f->sequence);
  put16(out + C_FLAGS, f->flags);
  put16(out + C_WATCHDOG_MS, f->watchdog_ms);
  for (i = 0; i < HB_NUM_LEGS; ++i) put16(out + C_DAC + 2 * i, f->dac[i]);
  put32(out + C_CRC, hb_crc32c(out, C_CRC));
  return HB_COMMAND_FRAME_SIZE;
}

/* The envelope, in the order the specification fixes: the CRC first (the last four bytes in
 * every version), so that noise is counted as a bad CRC and a well-formed frame of another
 * version as a version mismatch. */
static hb_frame_reason check_envelope(const uint8_t* data, size_t size, uint8_t type, size_t type_size) {
  if (size < HB_HEADER_SIZE + HB_CRC_SIZE) return HB_FRAME_SHORT;
  if (hb_crc32c(data, size - HB_CRC_SIZE) != get32(data + size - HB_CRC_SIZE)) return HB_FRAME_BAD_CRC;
  if (data[0] != HB_MAGIC_0 || data[1] != HB_MAGIC_1) return HB_FRAME_BAD_MAGIC;
  if (data[2] != HB_VERSION) return HB_FRAME_BAD_VERSION;
  if (data[3] != type) return HB_FRAME_BAD_TYPE;
  if (size != type_size) return HB_FRAME_BAD_SIZE;
  return HB_FRAME_OK;
}

hb_frame_reason hb_decode_sensor(const uint8_t* data, size_t size, hb_sensor_frame* f) {
  int i;
  const hb_frame_reason r = check_envelope(data, size, HB_TYPE_SENSOR, HB_SENSOR_FRAME_SIZE);
  if (r != HB_FRAME_OK) return r;
  f->sequence = get32(data + 4);
  f->board_time_us = get32(data + S_TIME);
  f->ack_sequence = get32(data + S_ACK);
  f->status = get16(data + S_STATUS);
  f->digital_inputs = get16(data + S_DIN);
  for (i = 0; i < HB_ADC_CHANNELS; ++i) f->adc[i] = get16(data + S_ADC + 2 * i);
  for (i = 0; i < 4; ++i) f->imu_quat[i] = get16s(data + S_QUAT + 2 * i);
  for (i = 0; i < 3; ++i) f->imu_rate[i] = get16s(data + S_RATE + 2 * i);
  f->imu_count = data[S_IMU_COUNT];
  f->last_reject = data[S_LAST_REJECT];
  for (i = 0; i < HB_NUM_LEGS; ++i) f->dac_applied[i] = get16(data + S_DAC + 2 * i);
  f->watchdog_count = get16(data + S_WATCHDOG_COUNT);
  f->rejected_count = get16(data + S_REJECTED);
  f->watchdog_ms = get16(data + S_WATCHDOG_MS);
  return HB_FRAME_OK;
}

hb_frame_reason hb_decode_command(const uint8_t* data, size_t size, hb_command_frame* f) {
  int i;
  const hb_frame_reason r = check_envelope(data, size, HB_TYPE_COMMAND, HB_COMMAND_FRAME_SIZE);
  if (r != HB_FRAME_OK) return r;
  f->sequence = get32(data + 4);
  f->flags = get16(data + C_FLAGS);
  f->watchdog_ms = get16(data + C_WATCHDOG_MS);
  for (i = 0; i < HB_NUM_LEGS; ++i) f->dac[i] = get16(data + C_DAC + 2 * i);
  return HB_FRAME_OK;
}

int hb_sequence_newer(uint32_t sequence, uint32_t last) {
  const uint32_t ahead = sequence - last; /* modulo 2^32 */
  return ahead != 0u && ahead < 0x80000000u;
}

size_t hb_cobs_encode(const uint8_t* data, size_t size, uint8_t* out, size_t capacity) {
  size_t read = 0, write = 1, code_at = 0;
  uint8_t code = 1;
  if (capacity < HB_COBS_MAX_SIZE(size)) return 0;
  while (read < size) {
    if (data[read] == 0u) {
      out[code_at] = code;
      code_at = write++;
      code = 1;
    } else {
      out[write++] = data[read];
      if (++code == 0xFFu) {
        out[code_at] = code;
        code_at = write++;
        code = 1;
      }
    }
    ++read;
  }
  out[code_at] = code;
  out[write++] = 0u;
  return write;
}

size_t hb_cobs_decode(const uint8_t* data, size_t size, uint8_t* out, size_t capacity) {
  size_t read = 0, write = 0;
  while (read < size) {
    const uint8_t code = data[read++];
    uint8_t k;
    if (code == 0u) return 0;
    for (k = 1; k < code; ++k) {
      if (read >= size || data[read] == 0u || write >= capacity) return 0;
      out[write++] = data[read++];
    }
    if (code != 0xFFu && read < size) {
      if (write >= capacity) return 0;
      out[write++] = 0u;
    }
  }
  return write;
}

const char* hb_frame_reason_name(hb_frame_reason reason) {
  switch (reason) {
    case HB_FRAME_OK: return "ok";
    case HB_FRAME_SHORT: return "short";
    case HB_FRAME_BAD_CRC: return "bad_crc";
    case HB_FRAME_BAD_MAGIC: return "bad_magic";
    case HB_FRAME_BAD_VERSION: return "bad_version";
    case HB_FRAME_BAD_TYPE: return "bad_type";
    case HB_FRAME_BAD_SIZE: return "bad_size";
    case HB_FRAME_OLD_SEQUENCE: return "old_sequence";
    case HB_FRAME_OUT_OF_RANGE: return "out_of_range";
    case HB_FRAME_REASON_COUNT: break;
  }
  return "unknown";
}
