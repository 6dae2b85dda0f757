/* The board's side of the link: intake, watchdog, e-stop latch, outputs (board.h). */
#include "hexa_board/board.h"

static uint16_t clamp_watchdog_ms(const hb_board_config* c, uint16_t requested_ms) {
  if (requested_ms == 0u) return c->watchdog_default_ms;
  if (requested_ms < c->watchdog_min_ms) return c->watchdog_min_ms;
  if (requested_ms > c->watchdog_max_ms) return c->watchdog_max_ms;
  return requested_ms;
}

void hb_board_init(hb_board* b, const hb_board_config* config) {
  int i;
  hb_board zero = {0};
  *b = zero;
  b->config = *config;
  b->watchdog_ms = config->watchdog_default_ms;
  b->watchdog_expired = 1;
  b->estop_latched = 1;
  b->estop_source = HB_STATUS_ESTOP_AT_POWER_UP;
  for (i = 0; i < HB_NUM_LEGS; ++i) b->dac_out[i] = config->safe_dac[i];
  b->status = HB_STATUS_VALVES_SAFE | HB_STATUS_WATCHDOG | HB_STATUS_ESTOP_LATCHED |
              HB_STATUS_ESTOP_AT_POWER_UP | HB_STATUS_NO_COMMAND_YET;
}

static hb_frame_reason refuse(hb_board* b, hb_frame_reason reason) {
  ++b->rejected_count;
  b->last_reject = (uint8_t)reason;
  return reason;
}

hb_frame_reason hb_board_receive(hb_board* b, const uint8_t* data, size_t size, uint32_t now_us) {
  hb_command_frame c;
  hb_frame_reason r;
  int i;
  uint16_t previous_flags;
  r = hb_decode_command(data, size, &c);
  if (r != HB_FRAME_OK) return refuse(b, r);
  if (b->have_command && !hb_sequence_newer(c.sequence, b->command.sequence)) {
    return refuse(b, HB_FRAME_OLD_SEQUENCE);
  }
  for (i = 0; i < HB_NUM_LEGS; ++i) {
    if (c.dac[i] > b->config.dac_max) return refuse(b, HB_FRAME_OUT_OF_RANGE);
  }
  previous_flags = b->have_command ? b->command.flags : 0u;
  if ((c.flags & HB_CMD_RESET_ESTOP) && !(previous_flags & HB_CMD_RESET_ESTOP)) b->reset_pending = 1;
  if (c.flags & HB_CMD_ESTOP) {
    b->estop_latched = 1;
    b->estop_source |= HB_STATUS_ESTOP_BY_HOST;
  }
  b->command = c;
  b->have_command = 1;
  b->last_command_us = now_us;
  b->watchdog_ms = clamp_watchdog_ms(&b->config, c.watchdog_ms);
  return HB_FRAME_OK;
}

static void update_estop(hb_board* b) {
  const int loop_closed = (b->inputs.digital_inputs & HB_DIN_ESTOP_LOOP_CLOSED) != 0u;
  if (!loop_closed) {
    b->estop_latched = 1;
    b->estop_source |= HB_STATUS_ESTOP_BY_INPUT;
  }
  if (!b->reset_pending) return;
  b->reset_pending = 0;
  /* A command that still asks for the e-stop cannot reset it. */
  if (loop_closed && !(b->command.flags & HB_CMD_ESTOP)) {
    b->estop_latched = 0;
    b->estop_source = 0u;
    b->reset_refused = 0;
  } else {
    b->reset_refused = 1;
  }
}

static void update_watchdog(hb_board* b) {
  /* Unsigned difference: correct across a wrap of the microsecond clock. */
  const uint32_t silent_us = b->now_us - b->last_command_us;
  const int expired = !b->have_command || silent_us > (uint32_t)b->watchdog_ms * 1000u;
  if (expired && !b->watchdog_expired && b->have_command) ++b->watchdog_count;
  b->watchdog_expired = expired;
}

void hb_board_tick(hb_board* b, const hb_board_inputs* inputs, uint32_t now_us,
                   uint16_t dac_out[HB_NUM_LEGS]) {
  int i, safe;
  b->inputs = *inputs;
  b->now_us = now_us;
  update_estop(b);
  update_watchdog(b);
  safe = b->watchdog_expired || b->estop_latched || (b->command.flags & HB_CMD_SAFE);
  for (i = 0; i < HB_NUM_LEGS; ++i) {
    b->dac_out[i] = safe ? b->config.safe_dac[i] : b->command.dac[i];
    dac_out[i] = b->dac_out[i];
  }
  b->status = 0u;
  if (safe) b->status |= HB_STATUS_VALVES_SAFE;
  if (b->watchdog_expired) b->status |= HB_STATUS_WATCHDOG;
  if (b->estop_latched) b->status |= HB_STATUS_ESTOP_LATCHED | b->estop_source;
  if (b->reset_refused) b->status |= HB_STATUS_RESET_REFUSED;
  if (b->have_command && (b->command.flags & HB_CMD_SAFE)) b->status |= HB_STATUS_HOST_SAFE;
  if (!b->have_command) b->status |= HB_STATUS_NO_COMMAND_YET;
}

size_t hb_board_frame(hb_board* b, uint8_t* out) {
  hb_sensor_frame f;
  int i;
  f.sequence = ++b->tx_sequence;
  f.board_time_us = b->now_us;
  f.ack_sequence = b->have_command ? b->command.sequence : 0u;
  f.status = b->status;
  f.digital_inputs = b->inputs.digital_inputs;
  for (i = 0; i < HB_ADC_CHANNELS; ++i) f.adc[i] = b->inputs.adc[i];
  for (i = 0; i < 4; ++i) f.imu_quat[i] = b->inputs.imu_quat[i];
  for (i = 0; i < 3; ++i) f.imu_rate[i] = b->inputs.imu_rate[i];
  f.imu_count = b->inputs.imu_count;
  f.last_reject = b->last_reject;
  for (i = 0; i < HB_NUM_LEGS; ++i) f.dac_applied[i] = b->dac_out[i];
  f.watchdog_count = b->watchdog_count;
  f.rejected_count = b->rejected_count;
  f.watchdog_ms = b->watchdog_ms;
  return hb_encode_sensor(&f, out);
}
