/*
 * Simulated arm motion and encoders (aacmm_sim.h). Float and integer only.
 */
#include "aacmm_sim.h"

#define TWO_PI_F 6.28318530717958647692f
#define INV_TWO_PI_F 0.15915494309189533577f
#define CPR_MAX (UINT64_C(1) << 32)

/* Joint ranges of the simulated arm: centre and half-range in rad. Joints 1,
 * 4 and 6 turn almost all the way round; 2, 3 and 5 are hinge-like. */
static const float centre_rad[AACMM_JOINTS] = {0.0f, 0.2f, -0.3f, 0.0f, 0.0f, 0.0f};
static const float amplitude_rad[AACMM_JOINTS] = {3.0f, 1.3f, 2.2f, 3.0f, 1.5f, 3.0f};
/* SWEEP periods, us: all different so the arm visits many combinations
 * (the seventh: joint 7's, also with ranges). */
static const uint32_t sweep_period_us[AACMM_JOINTS_MAX] = {
    25000000u, 19000000u, 15000000u, 12000000u, 9000000u, 7000000u, 11000000u};
/* ranges: a joint without limits moves as the built-in rolls. */
#define ROLL_AMPLITUDE_RAD 3.0f
#define ROLL_STATIC_RAD 0.5f
#define RANGE_LIMIT_MAX_RAD 12.5663706f /* 4 pi */
/* STATIC pose, rad. */
static const float static_pose_rad[AACMM_JOINTS] = {0.5f, 0.6f, -0.9f, 0.4f, 1.2f, -0.3f};

/* A 32-bit integer hash with good avalanche (two multiply-xorshift rounds). */
static uint32_t mix32(uint32_t x)
{
    x ^= x >> 16;
    x *= 0x7FEB352Du;
    x ^= x >> 15;
    x *= 0x846CA68Bu;
    x ^= x >> 16;
    return x;
}

/* Uniform in [-1, 1] from a hash. */
static float unit_from_hash(uint32_t h)
{
    return (float)(h >> 8) * (2.0f / 16777215.0f) - 1.0f;
}

/* Uniform in [-1, 1]: the waypoint of (seed, joint, segment k). */
static float waypoint_unit(uint32_t seed, int joint, uint64_t k)
{
    uint32_t h = mix32(seed ^ mix32((uint32_t)joint * 0x9E3779B9u + 0x632BE5ABu));
    h = mix32(h ^ (uint32_t)(k & 0xFFFFFFFFu));
    h = mix32(h ^ (uint32_t)(k >> 32) ^ 0x5BD1E995u);
    return unit_from_hash(h);
}

static float waypoint(uint32_t seed, int joint, uint64_t k)
{
    /* 0.9 of the range leaves room for the spline's overshoot. */
    return centre_rad[joint] + 0.9f * amplitude_rad[joint] * waypoint_unit(seed, joint, k);
}

/* Catmull-Rom through p0..p3 at u in [0, 1) (between p1 and p2). */
static float catmull_rom(float p0, float p1, float p2, float p3, float u)
{
    float u2 = u * u;
    float u3 = u2 * u;
    return 0.5f * (2.0f * p1 + (p2 - p0) * u + (2.0f * p0 - 5.0f * p1 + 4.0f * p2 - p3) * u2 +
                   (3.0f * p1 - p0 - 3.0f * p2 + p3) * u3);
}

/* ranges: joint j's centre and its sweep, walk and static amplitudes. */
static void range_of(const aacmm_sim_ranges_t *r, int j, float *c, float *sweep, float *walk,
                     float *stat)
{
    if (r->limited[j] != 0u) {
        float h = 0.5f * (r->hi_rad[j] - r->lo_rad[j]);
        *c = 0.5f * (r->hi_rad[j] + r->lo_rad[j]);
        *sweep = 0.95f * h;
        *walk = 0.75f * h; /* Catmull-Rom overshoots by at most 1.25x */
        *stat = 0.25f * h;
    } else {
        *c = 0.0f;
        *sweep = ROLL_AMPLITUDE_RAD;
        *walk = 0.9f * ROLL_AMPLITUDE_RAD;
        *stat = ROLL_STATIC_RAD;
    }
}

/* ranges: joint j (0 .. AACMM_JOINTS_MAX - 1) at time t_us, inside its range. */
static float range_angle(const aacmm_sim_t *sim, int j, uint64_t t_us)
{
    const aacmm_sim_config_t *cfg = &sim->cfg;
    float c;
    float sweep;
    float walk;
    float stat;
    range_of(cfg->ranges, j, &c, &sweep, &walk, &stat);
    switch (cfg->motion) {
    case AACMM_SIM_SWEEP: {
        uint32_t period = sweep_period_us[j];
        float phase = (float)(uint32_t)(t_us % period) / (float)period;
        float s;
        float co;
        aacmm_sincos_f32(TWO_PI_F * phase, &s, &co);
        return c + sweep * s;
    }
    case AACMM_SIM_WALK: {
        uint64_t k = t_us / AACMM_SIM_WALK_SEGMENT_US + 1u; /* +1: k - 1 never wraps */
        float u = (float)(uint32_t)(t_us % AACMM_SIM_WALK_SEGMENT_US) /
                  (float)AACMM_SIM_WALK_SEGMENT_US;
        return c + walk * catmull_rom(waypoint_unit(cfg->seed, j, k - 1u),
                                      waypoint_unit(cfg->seed, j, k),
                                      waypoint_unit(cfg->seed, j, k + 1u),
                                      waypoint_unit(cfg->seed, j, k + 2u), u);
    }
    case AACMM_SIM_STATIC:
    case AACMM_SIM_REPLAY:
    default:
        return c + stat;
    }
}

static int ranges_ok(const aacmm_sim_ranges_t *r)
{
    int j;
    for (j = 0; j < AACMM_JOINTS_MAX; j++) {
        float lo = r->lo_rad[j];
        float hi = r->hi_rad[j];
        if (r->limited[j] == 0u) {
            continue;
        }
        /* !(a <= b) also catches NaN */
        if (!(lo >= -RANGE_LIMIT_MAX_RAD) || !(hi <= RANGE_LIMIT_MAX_RAD) || !(lo < hi) ||
            !(hi - lo < TWO_PI_F)) {
            return 0;
        }
    }
    return 1;
}

/* REPLAY: the counts per pose (0 in the configuration: the six of old). */
static uint32_t replay_joints(const aacmm_sim_config_t *cfg)
{
    return cfg->replay_joints == 0u ? (uint32_t)AACMM_JOINTS : (uint32_t)cfg->replay_joints;
}

aacmm_status_t aacmm_sim_init(aacmm_sim_t *sim, const aacmm_sim_config_t *cfg)
{
    uint64_t i;
    if (sim == NULL || cfg == NULL) {
        return AACMM_ERR_NULL;
    }
    if (cfg->counts_per_rev < 2u || cfg->counts_per_rev > CPR_MAX ||
        cfg->noise_counts > AACMM_SIM_NOISE_MAX) {
        return AACMM_ERR_RANGE;
    }
    switch (cfg->motion) {
    case AACMM_SIM_STATIC:
    case AACMM_SIM_SWEEP:
    case AACMM_SIM_WALK:
        break;
    case AACMM_SIM_REPLAY:
        if (cfg->replay == NULL) {
            return AACMM_ERR_NULL;
        }
        if (cfg->replay_poses == 0u ||
            (cfg->replay_joints != 0u && (cfg->replay_joints < AACMM_JOINTS_MIN ||
                                          cfg->replay_joints > AACMM_JOINTS_MAX))) {
            return AACMM_ERR_RANGE;
        }
        for (i = 0; i < (uint64_t)cfg->replay_poses * replay_joints(cfg); i++) {
            if ((uint64_t)cfg->replay[i] >= cfg->counts_per_rev) {
                return AACMM_ERR_RANGE;
            }
        }
        break;
    default:
        return AACMM_ERR_RANGE;
    }
    if (cfg->ranges != NULL && !ranges_ok(cfg->ranges)) {
        return AACMM_ERR_RANGE;
    }
    sim->cfg = *cfg;
    sim->rng = mix32(cfg->seed ^ 0xA5A5A5A5u);
    if (sim->rng == 0u) {
        sim->rng = 0x12345678u;
    }
    sim->replay_pos = 0u;
    return AACMM_OK;
}

aacmm_status_t aacmm_sim_angles(const aacmm_sim_t *sim, uint64_t t_us,
                                float theta_rad[AACMM_JOINTS])
{
    int j;
    if (sim == NULL || theta_rad == NULL) {
        return AACMM_ERR_NULL;
    }
    if (sim->cfg.ranges != NULL && sim->cfg.motion != AACMM_SIM_REPLAY) {
        for (j = 0; j < AACMM_JOINTS; j++) {
            theta_rad[j] = range_angle(sim, j, t_us);
        }
        return AACMM_OK;
    }
    switch (sim->cfg.motion) {
    case AACMM_SIM_STATIC:
        for (j = 0; j < AACMM_JOINTS; j++) {
            theta_rad[j] = static_pose_rad[j];
        }
        return AACMM_OK;
    case AACMM_SIM_SWEEP:
        for (j = 0; j < AACMM_JOINTS; j++) {
            uint32_t period = sweep_period_us[j];
            float phase = (float)(uint32_t)(t_us % period) / (float)period;
            float s;
            float c;
            aacmm_sincos_f32(TWO_PI_F * phase, &s, &c);
            theta_rad[j] = centre_rad[j] + amplitude_rad[j] * s;
        }
        return AACMM_OK;
    case AACMM_SIM_WALK: {
        uint64_t k = t_us / AACMM_SIM_WALK_SEGMENT_US + 1u; /* +1: k - 1 never wraps */
        float u = (float)(uint32_t)(t_us % AACMM_SIM_WALK_SEGMENT_US) /
                  (float)AACMM_SIM_WALK_SEGMENT_US;
        float u2 = u * u;
        float u3 = u2 * u;
        for (j = 0; j < AACMM_JOINTS; j++) {
            float p0 = waypoint(sim->cfg.seed, j, k - 1u);
            float p1 = waypoint(sim->cfg.seed, j, k);
            float p2 = waypoint(sim->cfg.seed, j, k + 1u);
            float p3 = waypoint(sim->cfg.seed, j, k + 2u);
            theta_rad[j] = 0.5f * (2.0f * p1 + (p2 - p0) * u +
                                   (2.0f * p0 - 5.0f * p1 + 4.0f * p2 - p3) * u2 +
                                   (3.0f * p1 - p0 - 3.0f * p2 + p3) * u3);
        }
        return AACMM_OK;
    }
    case AACMM_SIM_REPLAY:
    default:
        return AACMM_ERR_UNSUPPORTED;
    }
}

uint32_t aacmm_sim_angle_to_counts(float theta_rad, uint64_t cpr)
{
    /* Whole turns off first, in 32-bit integers (native FPU conversions on
     * the M4F, no 64-bit float helpers): frac in [0, 1]. */
    float turns = theta_rad * INV_TWO_PI_F;
    int32_t whole = (int32_t)turns;
    float frac = turns - (float)whole;
    float cprf = cpr >= CPR_MAX ? 4294967296.0f : (float)(uint32_t)cpr;
    float x;
    uint64_t c;
    if (frac < 0.0f) {
        frac += 1.0f;
    }
    x = frac * cprf + 0.5f; /* round to nearest by truncation below */
    if (x >= cprf) {
        return 0u; /* a whole turn */
    }
    c = (uint32_t)x;
    if (c >= cpr) { /* cprf was rounded up from cpr */
        c -= cpr;
    }
    return (uint32_t)c;
}

/* xorshift32: period 2^32 - 1, never 0. */
static uint32_t next_random(aacmm_sim_t *sim)
{
    uint32_t x = sim->rng;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    sim->rng = x;
    return x;
}

/* counts + uniform noise in [-n, n], wrapped into 0 .. cpr-1. */
static uint32_t add_noise(aacmm_sim_t *sim, uint32_t counts)
{
    uint64_t n = sim->cfg.noise_counts;
    uint64_t cpr = sim->cfg.counts_per_rev;
    uint64_t span;
    uint64_t r;
    uint64_t off;
    if (n == 0u) {
        return counts;
    }
    span = 2u * n + 1u;
    r = (((uint64_t)next_random(sim) << 32) | next_random(sim)) % span; /* bias < 2^-31 */
    /* counts + r - n  (mod cpr), without negatives */
    off = (r + cpr - (n % cpr)) % cpr;
    return (uint32_t)(((uint64_t)counts + off) % cpr);
}

/* The seventh joint, for arm models of 7 joints (the first six keep the
 * motion, the noise sequence and the replay they had before): a handle roll
 * at 0.7 rad (STATIC, REPLAY) or sweeping +-2.5 rad in 11 s (SWEEP, WALK),
 * without noise. */
static float joint7_rad(const aacmm_sim_t *sim, uint64_t t_us)
{
    float phase;
    float s;
    float c;
    if (sim->cfg.ranges != NULL) {
        return range_angle(sim, AACMM_JOINTS, t_us);
    }
    if (sim->cfg.motion == AACMM_SIM_STATIC || sim->cfg.motion == AACMM_SIM_REPLAY) {
        return 0.7f;
    }
    phase = (float)(uint32_t)(t_us % 11000000u) / 11000000.0f;
    aacmm_sincos_f32(TWO_PI_F * phase, &s, &c);
    return 2.5f * s;
}

aacmm_status_t aacmm_sim_read(aacmm_sim_t *sim, uint64_t t_us, uint32_t counts[AACMM_JOINTS_MAX])
{
    int j;
    if (sim == NULL || counts == NULL) {
        return AACMM_ERR_NULL;
    }
    if (sim->cfg.motion == AACMM_SIM_REPLAY) {
        /* joints 1..K of the pose, noise in joint order (K = 6: the
         * sequence of old); 0 past K, joint 7 as below unless K = 7 */
        uint32_t k = replay_joints(&sim->cfg);
        const uint32_t *pose = sim->cfg.replay + (size_t)sim->replay_pos * k;
        for (j = 0; j < AACMM_JOINTS; j++) {
            counts[j] = (uint32_t)j < k ? add_noise(sim, pose[j]) : 0u;
        }
        counts[AACMM_JOINTS] =
            k == AACMM_JOINTS_MAX
                ? add_noise(sim, pose[AACMM_JOINTS])
                : aacmm_sim_angle_to_counts(joint7_rad(sim, t_us), sim->cfg.counts_per_rev);
        sim->replay_pos++;
        if (sim->replay_pos >= sim->cfg.replay_poses) {
            sim->replay_pos = 0u;
        }
        return AACMM_OK;
    }
    {
        float theta[AACMM_JOINTS];
        aacmm_status_t st = aacmm_sim_angles(sim, t_us, theta);
        if (st != AACMM_OK) {
            return st;
        }
        for (j = 0; j < AACMM_JOINTS; j++) {
            counts[j] =
                add_noise(sim, aacmm_sim_angle_to_counts(theta[j], sim->cfg.counts_per_rev));
        }
    }
    counts[AACMM_JOINTS] = aacmm_sim_angle_to_counts(joint7_rad(sim, t_us), sim->cfg.counts_per_rev);
    return AACMM_OK;
}

static uint64_t button_hold(uint64_t period)
{
    uint64_t hold = period / 2u;
    return hold > AACMM_SIM_BUTTON_HOLD_US ? AACMM_SIM_BUTTON_HOLD_US : hold;
}

uint64_t aacmm_sim_next_button_edge_us(const aacmm_sim_t *sim, uint64_t t_us)
{
    uint64_t period;
    uint64_t start;
    if (sim == NULL || sim->cfg.button_period_us == 0u) {
        return UINT64_MAX;
    }
    period = sim->cfg.button_period_us;
    if (t_us < period) {
        return period;
    }
    start = t_us - t_us % period; /* the press of the current period */
    if (t_us < start + button_hold(period)) {
        return start + button_hold(period);
    }
    return start + period;
}

uint8_t aacmm_sim_button(const aacmm_sim_t *sim, uint64_t t_us)
{
    uint64_t period;
    uint64_t hold;
    if (sim == NULL || sim->cfg.button_period_us == 0u) {
        return 0u;
    }
    period = sim->cfg.button_period_us;
    hold = button_hold(period);
    if (t_us < period) {
        return 0u;
    }
    return (t_us % period) < hold ? 1u : 0u;
}
