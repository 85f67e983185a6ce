/*
 * Simulated arm: a portable encoder source for the device application.
 *
 * Generates six joint readings as a function of time for a selectable motion
 * and converts them to raw encoder counts at a given resolution, with
 * optional uniform noise; also a periodic probe-button press. Used by the
 * POSIX simulator (aacmm-sim) and by boards without real encoders.
 *
 * Portable: float arithmetic only (the core's aacmm_sincos_f32, no libm, no
 * double), integer time, no heap, no libc beyond <stdint.h>/<stddef.h>.
 * The caller owns the state and the replay buffer.
 *
 * Motions:
 *   STATIC  a fixed pose (AACMM_SIM_STATIC_POSE_RAD): every read gives the
 *           same counts (plus noise, if any).
 *   SWEEP   joint i = centre_i + amplitude_i * sin(2 pi t / period_i), each
 *           joint through its range at its own slow period (7 .. 25 s).
 *   WALK    a smooth random walk through the workspace: every joint passes
 *           through a random waypoint inside its range every
 *           AACMM_SIM_WALK_SEGMENT_US, interpolated with a Catmull-Rom
 *           spline (continuous position and velocity). The waypoints are a
 *           hash of (seed, joint, segment), so the pose is a pure function of
 *           seed and time.
 *   REPLAY  raw counts from a caller buffer of poses of replay_joints (K,
 *           4..7) joints, one pose per read, in order, looping at the end
 *           (the resolution is not applied; noise is, on joints 1..K).
 *           Joints past K read 0, except joint 7, which holds 0.7 rad as
 *           with STATIC (a port refuses a file of another N than the arm's,
 *           so the device never uses them).
 *
 * Counts: reading = round(theta * cpr / (2 pi)) mod cpr, i.e. zero offset 0
 * and direction +1 at every joint: this matches the device's encoder
 * configuration {counts_per_rev = cpr, zero_offset_counts = 0, direction = +1}.
 * Float precision limits the simulated resolution to about 2^-24 turn: at
 * 32-bit resolution the low 8 bits of a noise-free reading are 0.
 */
#ifndef AACMM_SIM_H
#define AACMM_SIM_H

#include <stddef.h>
#include <stdint.h>

#include "aacmm/encoder_frame.h"
#include "aacmm/kinematics.h"
#include "aacmm/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum {
    AACMM_SIM_STATIC = 0,
    AACMM_SIM_SWEEP = 1,
    AACMM_SIM_WALK = 2,
    AACMM_SIM_REPLAY = 3
} aacmm_sim_motion_t;

#define AACMM_SIM_WALK_SEGMENT_US 4000000u /* one waypoint every 4 s */
#define AACMM_SIM_NOISE_MAX 0x40000000u     /* largest noise amplitude, counts */
#define AACMM_SIM_BUTTON_HOLD_US 200000u    /* how long a press lasts (at most half the period) */

/*
 * Joint ranges of an arm model for the motion (aacmm_sim_config_t.ranges):
 * every joint 1..7 then moves inside its own range (docs/simulator.md,
 * "Joint limits of the simulator's own motion"). A limited joint
 * (limited[j] = 1, lo_rad[j] < hi_rad[j], a span under 2 pi, within +-4 pi)
 * about its centre c with half range h: SWEEP c + 0.95 h sin, WALK waypoints
 * c + 0.75 h u (the spline overshoots by at most 1.25x: within 0.94 h),
 * STATIC c + 0.25 h; a joint without limits (limited[j] = 0) as a roll:
 * SWEEP +-3 rad, WALK waypoints +-2.7 rad, STATIC 0.5 rad.
 */
typedef struct {
    uint8_t limited[AACMM_JOINTS_MAX];
    float lo_rad[AACMM_JOINTS_MAX];
    float hi_rad[AACMM_JOINTS_MAX];
} aacmm_sim_ranges_t;

typedef struct {
    aacmm_sim_motion_t motion;
    uint32_t seed;            /* WALK waypoints and the noise generator */
    uint32_t noise_counts;    /* uniform +-noise_counts on every reading, 0 .. AACMM_SIM_NOISE_MAX */
    uint64_t counts_per_rev;  /* every joint, 2 .. 2^32 */
    const uint32_t *replay;   /* REPLAY: replay_poses * K counts, each < counts_per_rev */
    uint32_t replay_poses;    /* >= 1 for REPLAY */
    uint64_t button_period_us; /* a press every period (first at t = period); 0 = never */
    /* An arm model's joint limits (aacmm-sim --joint-limits), the caller's
     * (it must outlive the simulation): NULL (memset) keeps the built-in
     * motion of the paper's arm on joints 1..6 and joint 7's roll. */
    const aacmm_sim_ranges_t *ranges;
    /* REPLAY: K, the counts per pose (pose i's joint j at replay[K * i + j]),
     * AACMM_JOINTS_MIN .. AACMM_JOINTS_MAX; 0 (memset) means 6. Last, so
     * the struct keeps its size on 32-bit boards. */
    uint8_t replay_joints;
} aacmm_sim_config_t;

typedef struct {
    aacmm_sim_config_t cfg;
    uint32_t rng;        /* noise generator state, never 0 */
    uint32_t replay_pos; /* next replay pose */
} aacmm_sim_t;

/*
 * Check *cfg and set up *sim. AACMM_ERR_NULL, AACMM_ERR_RANGE (unknown
 * motion, resolution, noise, empty replay, replay_joints not 0 or 4..7, or
 * a replay count >= cpr; with
 * ranges a limited joint's range not finite, lo >= hi, a span of 2 pi or
 * more or a limit beyond +-4 pi), else
 * AACMM_OK. Cost: O(replay_poses) for the replay check.
 */
aacmm_status_t aacmm_sim_init(aacmm_sim_t *sim, const aacmm_sim_config_t *cfg);

/*
 * Noise-free joint angles in rad at time t_us (since the simulation began)
 * for STATIC, SWEEP and WALK. AACMM_ERR_NULL, AACMM_ERR_UNSUPPORTED for
 * REPLAY, else AACMM_OK. Cost: 6 sine evaluations (SWEEP) or 24 hashes (WALK).
 */
aacmm_status_t aacmm_sim_angles(const aacmm_sim_t *sim, uint64_t t_us,
                                float theta_rad[AACMM_JOINTS]);

/*
 * One encoder reading at time t_us: counts[i] < cpr (REPLAY: the next pose
 * on joints 1..K, see above) for joints 1..6 and a seventh (for 7-joint arm
 * models: 0.7 rad, the replay's own with K = 7, or a
 * noise-free sweep of +-2.5 rad in 11 s with SWEEP and WALK; with ranges
 * the seventh joint's own range, noise-free). Advances the
 * noise generator and the replay position. AACMM_ERR_NULL or
 * AACMM_OK. Cost: as aacmm_sim_angles plus 6 conversions.
 */
aacmm_status_t aacmm_sim_read(aacmm_sim_t *sim, uint64_t t_us, uint32_t counts[AACMM_JOINTS_MAX]);

/*
 * Convert one angle in rad (|theta| <= 1024) to a reading at resolution cpr
 * (2 .. 2^32): round(theta * cpr / 2 pi) mod cpr. O(1).
 */
uint32_t aacmm_sim_angle_to_counts(float theta_rad, uint64_t cpr);

/* Probe button at time t_us: 1 during the first
 * min(AACMM_SIM_BUTTON_HOLD_US, period / 2) us of every period after the
 * first, else 0. O(1). */
uint8_t aacmm_sim_button(const aacmm_sim_t *sim, uint64_t t_us);

/* The first time > t_us at which aacmm_sim_button changes, or UINT64_MAX if
 * it never does (no button period). Lets a port wake exactly at the edges.
 * O(1). */
uint64_t aacmm_sim_next_button_edge_us(const aacmm_sim_t *sim, uint64_t t_us);

/* ---- simulated encoders: counts to frames, bit by bit ------------------
 *
 * The encoder end of each joint's data line (aacmm/encoder_frame.h): a
 * BiSS-C or SSI slave that shifts the position out one clock at a time, as
 * the encoder's own logic does (the BiSS CRC computed in a 6-bit shift
 * register as the bits go out), sampled by a master that gives
 * aacmm_enc_clocks() clocks. Optionally one frame in fault_every is
 * corrupted, cycling through the faults the interface can show; a port
 * (the simulator, the boards) hands the frames to the device, which decodes
 * them exactly as it would a real encoder's. */

/* Faults the simulated encoders inject. */
typedef enum {
    AACMM_SIM_ENC_OK = 0,
    AACMM_SIM_ENC_BIT_FLIP = 1,   /* one position/nE/nW bit inverted on the line (BiSS: CRC fault) */
    AACMM_SIM_ENC_ERROR_BIT = 2,  /* BiSS nE = 0 with a matching CRC */
    AACMM_SIM_ENC_WARNING = 3,    /* BiSS nW = 0 with a matching CRC: position still valid */
    AACMM_SIM_ENC_STUCK_LOW = 4,  /* every sample 0 */
    AACMM_SIM_ENC_STUCK_HIGH = 5, /* every sample 1 (no encoder) */
    AACMM_SIM_ENC_NO_ANSWER = 6,  /* the interface reports no answer (n_bits 0) */
    AACMM_SIM_ENC_NO_START = 7,   /* BiSS: the Ack never ends */
    AACMM_SIM_ENC_SHORT = 8,      /* the frame stops before its end */
    AACMM_SIM_ENC_FRAMING = 9,    /* SSI: the line is high after the LSB */
    AACMM_SIM_ENC_KINDS = 10
} aacmm_sim_enc_fault_t;

typedef struct {
    aacmm_enc_joint_config_t joint[AACMM_JOINTS_MAX]; /* every joint a frame interface */
    uint32_t fault_every; /* corrupt one frame in fault_every (counted over all joints); 0 = never */
    uint32_t seed;        /* which bit flips, Ack lengths */
} aacmm_sim_encoders_config_t;

typedef struct {
    aacmm_sim_encoders_config_t cfg;
    uint32_t rng;
    uint32_t frames;                            /* frames produced (wraps) */
    uint32_t next_kind;                         /* rotation through the interface's faults */
    uint32_t injected[AACMM_SIM_ENC_KINDS];     /* frames produced per kind (index 0: clean) */
} aacmm_sim_encoders_t;

/* Check *cfg (valid frame interfaces on all joints) and set up *enc.
 * AACMM_ERR_NULL, AACMM_ERR_RANGE, else AACMM_OK. O(1). */
aacmm_status_t aacmm_sim_encoders_init(aacmm_sim_encoders_t *enc,
                                       const aacmm_sim_encoders_config_t *cfg);

/* The seven frames for the seven positions (each < 2^bits of its joint,
 * else AACMM_ERR_RANGE and no frames), with the configured corruption on
 * joints 1..6 (the seventh, for 7-joint arm models, is never corrupted; a
 * seventh joint left zero in the configuration has no encoder: its frame is
 * empty).
 * AACMM_ERR_NULL, AACMM_ERR_RANGE or AACMM_OK. Cost: O(total clocks). */
aacmm_status_t aacmm_sim_encoders_frames(aacmm_sim_encoders_t *enc,
                                         const uint32_t counts[AACMM_JOINTS_MAX],
                                         aacmm_enc_frame_t frames[AACMM_JOINTS_MAX]);

/* One frame of *cfg carrying position (masked to cfg->bits), with fault
 * inject (aacmm_sim_enc_fault_t); variant picks the Ack length (BiSS) and
 * the flipped bit. Built clock by clock from the slave's line level. A
 * fault the interface cannot show (BiSS-only or SSI-only) is ignored.
 * O(clocks). */
void aacmm_sim_encoder_frame(const aacmm_enc_joint_config_t *cfg, uint32_t position,
                             uint8_t inject, uint32_t variant, aacmm_enc_frame_t *out);

/* Smallest number of position bits that holds counts 0 .. cpr-1 (1..32). */
uint8_t aacmm_sim_bits_for_cpr(uint64_t cpr);

#ifdef __cplusplus
}
#endif

#endif /* AACMM_SIM_H */
