/* Board link protocol, version 1 (docs/board_protocol.md): frame layout, CRC-32C, COBS.
 *
 * Portable C99: no heap, no OS calls, no floating point. Shared by the board (board.h) and
 * the host (device/), so that the layout has one home. Every multi-byte field is
 * little-endian; frames are encoded and decoded byte by byte (no struct overlay), so the
 * code does not depend on the target's endianness or alignment. */
#ifndef HEXA_BOARD_PROTOCOL_H
#define HEXA_BOARD_PROTOCOL_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define HB_MAGIC_0 0x48u /* 'H' */
#define HB_MAGIC_1 0x42u /* 'B' */
#define HB_VERSION 1u

#define HB_TYPE_SENSOR 0x01u  /* board -> host, one per board tick */
#define HB_TYPE_COMMAND 0x02u /* host -> board, one per host tick */

#define HB_NUM_LEGS 6
/* ADC channels: potentiometers 0..5 (leg i at i), chamber pressures 6..17 (leg i's cap side
 * at 6 + 2i, rod side at 7 + 2i), supply pressure 18. */
#define HB_ADC_POT(leg) (leg)
#define HB_ADC_CHAMBER1(leg) (6 + 2 * (leg))
#define HB_ADC_CHAMBER2(leg) (7 + 2 * (leg))
#define HB_ADC_SUPPLY 18
#define HB_ADC_CHANNELS 19

/* Digital inputs (bit set = contact closed). The e-stop loop is normally closed: a cleared
 * bit is an open loop (button pressed, wire cut, connector out). */
#define HB_DIN_ESTOP_LOOP_CLOSED (1u << 0)
#define HB_DIN_RETRACTED(leg) (1u << (1 + 2 * (leg))) /* end switch at the short end */
#define HB_DIN_EXTENDED(leg) (1u << (2 + 2 * (leg)))  /* end switch at the long end */

/* Sensor frame status flags. */
#define HB_STATUS_VALVES_SAFE (1u << 0)     /* every valve output is at its safe value */
#define HB_STATUS_WATCHDOG (1u << 1)        /* no valid command within the watchdog time */
#define HB_STATUS_ESTOP_LATCHED (1u << 2)   /* e-stop latched (until a reset) */
#define HB_STATUS_ESTOP_BY_INPUT (1u << 3)  /* the latch was set by the loop opening */
#define HB_STATUS_ESTOP_BY_HOST (1u << 4)   /* the latch was set by HB_CMD_ESTOP */
#define HB_STATUS_RESET_REFUSED (1u << 5)   /* the last reset came while the loop was open */
#define HB_STATUS_HOST_SAFE (1u << 6)       /* the host asked for the safe state */
#define HB_STATUS_NO_COMMAND_YET (1u << 7)  /* no valid command since power-up */
#define HB_STATUS_ESTOP_AT_POWER_UP (1u << 8) /* latched since power-up, never reset */

/* Command frame flags. */
#define HB_CMD_RESET_ESTOP (1u << 0) /* acts on its 0 -> 1 edge, only with the loop closed */
#define HB_CMD_ESTOP (1u << 1)       /* latch the e-stop (operator command) */
#define HB_CMD_SAFE (1u << 2)        /* valves at their safe values; link stays alive */

/* Frame sizes, the CRC-32C included (always the last four bytes, in every version). */
#define HB_HEADER_SIZE 8
#define HB_CRC_SIZE 4
#define HB_SENSOR_FRAME_SIZE 96
#define HB_COMMAND_FRAME_SIZE 28
#define HB_MAX_FRAME_SIZE HB_SENSOR_FRAME_SIZE
/* COBS adds at most one byte per 254 and a delimiter (serial transport). */
#define HB_COBS_MAX_SIZE(n) ((n) + (n) / 254 + 2)

/* Why a received frame was refused. The values are part of the protocol (sensor frames carry
 * the board's last one in `last_reject`). */
typedef enum {
  HB_FRAME_OK = 0,
  HB_FRAME_SHORT = 1,         /* fewer bytes than a header + CRC */
  HB_FRAME_BAD_CRC = 2,       /* CRC-32C of the bytes before the last four differs */
  HB_FRAME_BAD_MAGIC = 3,     /* not "HB" */
  HB_FRAME_BAD_VERSION = 4,   /* a protocol version this side does not speak */
  HB_FRAME_BAD_TYPE = 5,      /* not the frame type this side expects */
  HB_FRAME_BAD_SIZE = 6,      /* a size other than the type's */
  HB_FRAME_OLD_SEQUENCE = 7,  /* sequence not newer than the last accepted (dup / reorder) */
  HB_FRAME_OUT_OF_RANGE = 8,  /* a value outside its allowed range */
  HB_FRAME_REASON_COUNT = 9
} hb_frame_reason;

typedef struct {
  uint32_t sequence;        /* board's frame counter, +1 per frame sent */
  uint32_t board_time_us;   /* board's clock when the inputs were sampled (wraps) */
  uint32_t ack_sequence;    /* sequence of the last accepted command (0: none yet) */
  uint16_t status;          /* HB_STATUS_* */
  uint16_t digital_inputs;  /* HB_DIN_* */
  uint16_t adc[HB_ADC_CHANNELS];
  int16_t imu_quat[4];      /* w, x, y, z of R_BP, Q14 (16384 = 1) */
  int16_t imu_rate[3];      /* angular rate x, y, z, raw counts (calibrated by the host) */
  uint8_t imu_count;        /* +1 per fresh IMU sample (wraps) */
  uint8_t last_reject;      /* hb_frame_reason of the last refused command */
  uint16_t dac_applied[HB_NUM_LEGS]; /* what the valve outputs are driven with */
  uint16_t watchdog_count;  /* times the watchdog fired since power-up (wraps) */
  uint16_t rejected_count;  /* command frames refused since power-up (wraps) */
  uint16_t watchdog_ms;     /* watchdog time in force */
} hb_sensor_frame;

typedef struct {
  uint32_t sequence;        /* host's frame counter, +1 per frame sent */
  uint16_t flags;           /* HB_CMD_* */
  uint16_t watchdog_ms;     /* requested watchdog time; 0 = the board's default */
  uint16_t dac[HB_NUM_LEGS];
} hb_command_frame;

/* CRC-32C (Castagnoli): reflected polynomial 0x82F63B78, init and final xor 0xFFFFFFFF.
 * hb_crc32c("123456789", 9) == 0xE3069283. */
uint32_t hb_crc32c(const uint8_t* data, size_t size);
/* Continues a CRC: hb_crc32c_update(0, a, n) == hb_crc32c(a, n); the value carries over. */
uint32_t hb_crc32c_update(uint32_t crc, const uint8_t* data, size_t size);

/* Encode into `out` (at least HB_*_FRAME_SIZE bytes); return the frame size. */
size_t hb_encode_sensor(const hb_sensor_frame* frame, uint8_t* out);
size_t hb_encode_command(const hb_command_frame* frame, uint8_t* out);

/* Check a frame's envelope in the protocol's order (size, CRC, magic, version, type, size of
 * the type) and decode it. The sequence and the values are the receiver's to judge. */
hb_frame_reason hb_decode_sensor(const uint8_t* data, size_t size, hb_sensor_frame* frame);
hb_frame_reason hb_decode_command(const uint8_t* data, size_t size, hb_command_frame* frame);

/* Serial-line tool: is `sequence` newer than `last` (modulo 2^32, within half the range)? */
int hb_sequence_newer(uint32_t sequence, uint32_t last);

/* COBS (Consistent Overhead Byte Stuffing) for a byte-stream transport: the encoded frame
 * holds no zero byte and is followed by one 0x00 delimiter. Returns the encoded size with the
 * delimiter, or 0 if `capacity` is too small. */
size_t hb_cobs_encode(const uint8_t* data, size_t size, uint8_t* out, size_t capacity);
/* Decodes one COBS block (without its delimiter). Returns the decoded size, or 0 on a zero
 * byte inside, a truncated block or a too small `capacity`. */
size_t hb_cobs_decode(const uint8_t* data, size_t size, uint8_t* out, size_t capacity);

/* Short name of a reason ("bad_crc"), for counters and logs. */
const char* hb_frame_reason_name(hb_frame_reason reason);

#ifdef __cplusplus
}
#endif

#endif /* HEXA_BOARD_PROTOCOL_H */
