// The exit codes of every program of the system, in one place (docs/exit_codes.md lists them
// with their meaning per program; the generated systemd units and the launcher read them from
// here). 0, 1 and 2 mean the same for every program; the codes above 2 say what happened to the
// platform or to the result, and each program uses only the ones its table lists.
#pragma once

namespace hexa::exit_code {

inline constexpr int kOk = 0;           // success: the work completed
inline constexpr int kRunError = 1;     // an error at run time (a file, a DDS entity, a failed process)
inline constexpr int kUsage = 2;        // a usage or configuration error named before any work

// Services.
inline constexpr int kPlantLockstepStall = 3;     // hexa_plant_sim: a leg / the loop stopped answering
inline constexpr int kPlantNonFinite = 4;         // hexa_plant_sim: the plant's state became non-finite
inline constexpr int kPlantDeviceLost = 7;        // hexa_plant_sim: the device (I/O board) stopped answering
inline constexpr int kPeersNotMatched = 3;        // hexa_task_space, hexa_leg_ctrl: peers not matched at start-up
inline constexpr int kSupervisorHeld = 5;         // hexa_task_space --exit-when-done: HOLD, no reset in time
inline constexpr int kStoppedByOperator = 6;      // hexa_task_space --exit-when-done: `stop` ended the motion

// hexa_session (the launcher).
inline constexpr int kSessionHeld = 3;            // the supervisor held and no reset came in time
inline constexpr int kSessionPlantStopped = 4;    // the plant stopped (stall, peers, non-finite state)
inline constexpr int kSessionSupervisorLost = 5;  // the supervisor's process died
inline constexpr int kSessionStoppedByOperator = 6;
inline constexpr int kSessionRecordingLoss = 7;   // the trajectory ended, the recording lost samples

// Tools.
inline constexpr int kNotAnswered = 3;            // hexa_operator: not acknowledged / not answered
inline constexpr int kRefused = 4;                // hexa_operator: the supervisor refused or rejected it

}  // namespace hexa::exit_code
