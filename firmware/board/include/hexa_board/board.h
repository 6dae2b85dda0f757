/* The board's side of the link (docs/board_protocol.md), written once for the firmware and the
 * board emulator: command intake, the watchdog, the e-stop latch, the valve outputs and the
 * sensor frame. Portable C99: no heap, no OS calls, no floating point; time is an argument
 * (a free-running microsecond clock that may wrap).
 *
 * Per board tick the firmware does:
 *   sample the inputs -> hb_board_tick() -> drive the DACs with its output -> hb_board_frame()
 *   -> send the frame;
 * and for every datagram (or COBS block) received: hb_board_receive().
 *
 * Safety rules, all in hb_board_tick():
 *   - valves at their safe values unless a valid command arrived within the watchdog time,
 *     the e-stop is not latched and the host did not ask for the safe state;
 *   - the e-stop latches when the normally-closed loop opens, when a command carries
 *     HB_CMD_ESTOP, and at power-up; only the 0 -> 1 edge of HB_CMD_RESET_ESTOP with the loop
 *     closed clears it. */
#ifndef HEXA_BOARD_BOARD_H
#define HEXA_BOARD_BOARD_H

#include "hexa_board/protocol.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
  uint16_t safe_dac[HB_NUM_LEGS]; /* each valve's safe value (MPYE: 5 V, spool centred) */
  uint16_t dac_max;               /* largest DAC value; a command above it is refused */
  uint16_t watchdog_default_ms;   /* before the first command, and when a command asks 0 */
  uint16_t watchdog_min_ms;       /* a command's request is clamped into [min, max] */
  uint16_t watchdog_max_ms;
} hb_board_config;

typedef struct {
  uint16_t adc[HB_ADC_CHANNELS];
  int16_t imu_quat[4];
  int16_t imu_rate[3];
  uint8_t imu_count;
  uint16_t digital_inputs; /* HB_DIN_* */
} hb_board_inputs;

/* All of the board's state; the caller owns the storage (static in firmware). */
typedef struct {
  hb_board_config config;
  hb_command_frame command; /* the last accepted command */
  int have_command;
  uint32_t last_command_us; /* board time the last accepted command arrived */
  uint16_t watchdog_ms;
  int watchdog_expired;
  uint16_t watchdog_count;
  int estop_latched;
  uint16_t estop_source;    /* HB_STATUS_ESTOP_BY_* / AT_POWER_UP */
  int reset_pending;        /* a reset edge arrived; judged at the next tick */
  int reset_refused;
  uint16_t rejected_count;
  uint8_t last_reject;
  uint32_t tx_sequence;
  uint32_t now_us;          /* time of the last tick */
  hb_board_inputs inputs;   /* inputs of the last tick */
  uint16_t dac_out[HB_NUM_LEGS];
  uint16_t status;
} hb_board;

/* Power-up: no command, e-stop latched, valves safe. */
void hb_board_init(hb_board* board, const hb_board_config* config);

/* One received frame. Accepted (HB_FRAME_OK) only if well formed (hb_decode_command), newer
 * than the last accepted command and with every DAC value <= dac_max; a refused frame is
 * counted and changes nothing else. Returns the verdict. */
hb_frame_reason hb_board_receive(hb_board* board, const uint8_t* data, size_t size, uint32_t now_us);

/* One board tick with freshly sampled inputs: e-stop latch and reset, watchdog, outputs.
 * Writes the values to drive the six valve DACs with into dac_out. */
void hb_board_tick(hb_board* board, const hb_board_inputs* inputs, uint32_t now_us,
                   uint16_t dac_out[HB_NUM_LEGS]);

/* The sensor frame of the last tick (its inputs, status and outputs) into `out`
 * (HB_SENSOR_FRAME_SIZE bytes); the sequence advances. Returns the frame size. */
size_t hb_board_frame(hb_board* board, uint8_t* out);

#ifdef __cplusplus
}
#endif

#endif /* HEXA_BOARD_BOARD_H */
