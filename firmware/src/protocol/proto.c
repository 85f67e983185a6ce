#include "aacmm/proto.h"

#include <string.h>

#include "aacmm/crc32.h"
#include "aacmm/frame.h"

/* ---- little-endian writer / reader with sticky bounds errors ------------ */

typedef struct {
    uint8_t *buf; /* NULL: only run the CRC over the bytes (no buffer needed) */
    size_t cap;
    size_t pos;
    aacmm_status_t err;
    uint32_t crc; /* running CRC-32 when buf is NULL */
} wr_t;

typedef struct {
    const uint8_t *buf;
    size_t len;
    size_t pos;
    aacmm_status_t err;
} rd_t;

static void wr_u8(wr_t *w, uint8_t v)
{
    if (w->err != AACMM_OK) {
        return;
    }
    if (w->buf == NULL) {
        w->crc = aacmm_crc32_update(w->crc, &v, 1u);
        w->pos++;
        return;
    }
    if (w->pos >= w->cap) {
        w->err = AACMM_ERR_BUFFER;
        return;
    }
    w->buf[w->pos++] = v;
}

static void wr_u16(wr_t *w, uint16_t v)
{
    wr_u8(w, (uint8_t)(v & 0xFFu));
    wr_u8(w, (uint8_t)(v >> 8));
}

static void wr_u32(wr_t *w, uint32_t v)
{
    wr_u16(w, (uint16_t)(v & 0xFFFFu));
    wr_u16(w, (uint16_t)(v >> 16));
}

static void wr_u64(wr_t *w, uint64_t v)
{
    wr_u32(w, (uint32_t)(v & 0xFFFFFFFFu));
    wr_u32(w, (uint32_t)(v >> 32));
}

static uint32_t f32_bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

static uint64_t f64_bits(double f)
{
    uint64_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

static int f32_bits_finite(uint32_t u)
{
    return ((u >> 23) & 0xFFu) != 0xFFu;
}

static int f64_bits_finite(uint64_t u)
{
    return ((u >> 52) & 0x7FFu) != 0x7FFu;
}

static void wr_fail(wr_t *w, aacmm_status_t e)
{
    if (w->err == AACMM_OK) {
        w->err = e;
    }
}

static void wr_f32(wr_t *w, float f)
{
    uint32_t u = f32_bits(f);
    if (!f32_bits_finite(u)) {
        wr_fail(w, AACMM_ERR_NOT_FINITE);
    }
    wr_u32(w, u);
}

static void wr_f64(wr_t *w, double f)
{
    uint64_t u = f64_bits(f);
    if (!f64_bits_finite(u)) {
        wr_fail(w, AACMM_ERR_NOT_FINITE);
    }
    wr_u64(w, u);
}

static uint8_t rd_u8(rd_t *r)
{
    if (r->err != AACMM_OK) {
        return 0u;
    }
    if (r->pos >= r->len) {
        r->err = AACMM_ERR_LENGTH;
        return 0u;
    }
    return r->buf[r->pos++];
}

static uint16_t rd_u16(rd_t *r)
{
    uint16_t lo = rd_u8(r);
    uint16_t hi = rd_u8(r);
    return (uint16_t)(lo | (uint16_t)(hi << 8));
}

static uint32_t rd_u32(rd_t *r)
{
    uint32_t lo = rd_u16(r);
    uint32_t hi = rd_u16(r);
    return lo | (hi << 16);
}

static uint64_t rd_u64(rd_t *r)
{
    uint64_t lo = rd_u32(r);
    uint64_t hi = rd_u32(r);
    return lo | (hi << 32);
}

static void rd_fail(rd_t *r, aacmm_status_t e)
{
    if (r->err == AACMM_OK) {
        r->err = e;
    }
}

static float rd_f32(rd_t *r)
{
    uint32_t u = rd_u32(r);
    float f;
    if (!f32_bits_finite(u)) {
        rd_fail(r, AACMM_ERR_NOT_FINITE);
        u = 0u;
    }
    memcpy(&f, &u, sizeof f);
    return f;
}

static double rd_f64(rd_t *r)
{
    uint64_t u = rd_u64(r);
    double f;
    if (!f64_bits_finite(u)) {
        rd_fail(r, AACMM_ERR_NOT_FINITE);
        u = 0u;
    }
    memcpy(&f, &u, sizeof f);
    return f;
}

/* ---- payload pieces ---------------------------------------------------- */

static void wr_f64_array(wr_t *w, const double *v, size_t n)
{
    size_t i;
    for (i = 0; i < n; i++) {
        wr_f64(w, v[i]);
    }
}

static void rd_f64_array(rd_t *r, double *v, size_t n)
{
    size_t i;
    for (i = 0; i < n; i++) {
        v[i] = rd_f64(r);
    }
}

static void wr_i16(wr_t *w, int16_t v)
{
    wr_u16(w, (uint16_t)v);
}

static int16_t u16_to_i16(uint16_t u)
{
    int32_t v = (u >= 0x8000u) ? (int32_t)u - 0x10000 : (int32_t)u;
    return (int16_t)v;
}

static int16_t rd_i16(rd_t *r)
{
    return u16_to_i16(rd_u16(r));
}

static unsigned popcount8(unsigned v)
{
    unsigned n = 0u;
    while (v != 0u) {
        n += v & 1u;
        v >>= 1;
    }
    return n;
}

/* The header's u32 at offset 4: K_i in nibble i, H in bit 28. */
static uint32_t hdr_em(const uint8_t *h)
{
    return (uint32_t)h[4] | ((uint32_t)h[5] << 8) | ((uint32_t)h[6] << 16) |
           ((uint32_t)h[7] << 24);
}

/* Sum of the seven raw K nibbles (any values; those past N count too, so
 * the length is read before the ranges). */
static size_t hdr_ksum(uint32_t em)
{
    size_t i;
    size_t s = 0u;
    for (i = 0; i < (size_t)AACMM_JOINTS_MAX; i++) {
        s += (size_t)((em >> (4u * i)) & 0xFu);
    }
    return s;
}

/* Size of a parameter set from its raw header bytes (any values). */
static size_t param_set_len_raw(const uint8_t *h)
{
    size_t n = h[0];
    size_t p = 4u * n + popcount8(h[3]) + h[1];
    uint32_t em = hdr_em(h);
    return AACMM_PARAM_SET_BYTES(n, p, hdr_ksum(em), (size_t)((em >> AACMM_PARAM_THERMAL_BIT) & 1u));
}

/* The header rule: N 4..7, tip 1 or 3, convention and beta bits only for
 * joints 1..N (no beta on joint 1), K_i <= 4 for joints 1..N and 0 past N,
 * thermal 0/1, bits 29..31 of the error-model word 0. */
static int param_header_ok(const uint8_t *h)
{
    unsigned n = h[0];
    unsigned mask;
    unsigned i;
    uint32_t em = hdr_em(h);
    if (n < (unsigned)AACMM_JOINTS_MIN || n > (unsigned)AACMM_JOINTS_MAX) {
        return 0;
    }
    for (i = 0; i < 7u; i++) {
        uint32_t k = (em >> (4u * i)) & 0xFu;
        if (k > (uint32_t)AACMM_HARMONICS_MAX || (i >= n && k != 0u)) {
            return 0;
        }
    }
    mask = (1u << n) - 1u;
    return (h[1] == (uint8_t)AACMM_TIP_Z || h[1] == (uint8_t)AACMM_TIP_XYZ) &&
           (h[2] & ~mask) == 0u && (h[3] & ~(mask & ~1u)) == 0u &&
           (em >> (AACMM_PARAM_THERMAL_BIT + 1u)) == 0u;
}

/* The header bytes of *p, or 0 if its shape, encoders or error model
 * cannot be carried (then *err says why). */
/* Not +0.0 (bit for bit: -0.0 is a value the layout would lose too). */
static int nz(double v)
{
    return f64_bits(v) != 0u;
}

static int ref_temp_ok(int16_t t)
{
    return t >= (int16_t)AACMM_REF_TEMP_MIN && t <= (int16_t)AACMM_REF_TEMP_MAX;
}

static aacmm_status_t param_header(const aacmm_param_set_t *p, uint8_t h[8])
{
    const aacmm_shape_t *sh = &p->arm.shape;
    size_t i;
    size_t n;
    size_t k;
    unsigned conv = 0u;
    unsigned beta = 0u;
    uint32_t em = 0u;
    if (aacmm_shape_validate(sh) != AACMM_OK || p->enc.joints != sh->joints ||
        p->err.thermal > 1u) {
        return AACMM_ERR_RANGE;
    }
    n = sh->joints;
    for (i = 0; i < n; i++) {
        conv |= (unsigned)(sh->convention[i] != 0u) << i;
        beta |= (unsigned)(sh->beta[i] != 0u) << i;
    }
    /* Everything the layout does not carry must be 0 (canonical encoding);
     * encoder entries past N are ignored (aacmm_arm_encoders_t). */
    for (i = 0; i < (size_t)AACMM_JOINTS_MAX; i++) {
        uint8_t ki = p->err.harmonics[i];
        if (ki > (uint8_t)AACMM_HARMONICS_MAX || (i >= n && ki != 0u)) {
            return AACMM_ERR_RANGE;
        }
        em |= (uint32_t)ki << (4u * i);
        if (i >= n && (nz(p->arm.theta_offset_rad[i]) || nz(p->arm.alpha_rad[i]) ||
                       nz(p->arm.d_mm[i]) || nz(p->arm.a_mm[i]) || p->err.cte[i] != 0)) {
            return AACMM_ERR_RANGE;
        }
        if ((i >= n || sh->beta[i] == 0u) && nz(p->arm.beta_rad[i])) {
            return AACMM_ERR_RANGE;
        }
        if (p->err.thermal == 0u && p->err.cte[i] != 0) {
            return AACMM_ERR_RANGE;
        }
        for (k = 0; k < (size_t)AACMM_HARMONICS_MAX; k++) {
            if (k >= (size_t)ki && (p->err.harm_cos[i][k] != 0 || p->err.harm_sin[i][k] != 0)) {
                return AACMM_ERR_RANGE;
            }
        }
    }
    if (p->err.thermal == 0u ? p->err.ref_temp != 0 : !ref_temp_ok(p->err.ref_temp)) {
        return AACMM_ERR_RANGE;
    }
    if (sh->tip == (uint8_t)AACMM_TIP_Z && (nz(p->arm.tip_mm[0]) || nz(p->arm.tip_mm[1]))) {
        return AACMM_ERR_RANGE;
    }
    em |= (uint32_t)p->err.thermal << AACMM_PARAM_THERMAL_BIT;
    h[0] = sh->joints;
    h[1] = sh->tip;
    h[2] = (uint8_t)conv;
    h[3] = (uint8_t)beta;
    h[4] = (uint8_t)(em & 0xFFu);
    h[5] = (uint8_t)((em >> 8) & 0xFFu);
    h[6] = (uint8_t)((em >> 16) & 0xFFu);
    h[7] = (uint8_t)(em >> 24);
    return AACMM_OK;
}

static aacmm_status_t enc_check(const aacmm_arm_encoders_t *e)
{
    return aacmm_arm_encoders_validate(e);
}

static void wr_params(wr_t *w, const aacmm_param_set_t *p)
{
    uint8_t h[8];
    size_t i;
    size_t k;
    size_t n;
    aacmm_status_t st = param_header(p, h);
    if (st != AACMM_OK) {
        wr_fail(w, st);
        return;
    }
    n = h[0];
    for (i = 0; i < 8u; i++) {
        wr_u8(w, h[i]);
    }
    wr_f64_array(w, p->arm.theta_offset_rad, n);
    wr_f64_array(w, p->arm.alpha_rad, n);
    wr_f64_array(w, p->arm.d_mm, n);
    wr_f64_array(w, p->arm.a_mm, n);
    for (i = 0; i < n; i++) {
        if (p->arm.shape.beta[i] != 0u) {
            wr_f64(w, p->arm.beta_rad[i]);
        }
    }
    if (p->arm.shape.tip == (uint8_t)AACMM_TIP_XYZ) {
        wr_f64_array(w, p->arm.tip_mm, 3u);
    } else {
        wr_f64(w, p->arm.tip_mm[2]);
    }
    st = enc_check(&p->enc);
    if (st != AACMM_OK) {
        wr_fail(w, st);
        return;
    }
    for (i = 0; i < n; i++) {
        wr_u32(w, (uint32_t)(p->enc.counts_per_rev[i] - 1u));
    }
    for (i = 0; i < n; i++) {
        wr_u32(w, p->enc.zero_offset_counts[i]);
    }
    for (i = 0; i < n; i++) {
        wr_u8(w, (uint8_t)p->enc.direction[i]);
    }
    for (i = 0; i < n; i++) {
        for (k = 0; k < p->err.harmonics[i]; k++) {
            wr_i16(w, p->err.harm_cos[i][k]);
            wr_i16(w, p->err.harm_sin[i][k]);
        }
    }
    if (p->err.thermal != 0u) {
        for (i = 0; i < n; i++) {
            wr_i16(w, p->err.cte[i]);
        }
        wr_i16(w, p->err.ref_temp);
    }
}

/* Decode a parameter set from r->buf[r->pos ..], which must hold exactly
 * its bytes up to r->len. */
static void rd_params(rd_t *r, aacmm_param_set_t *p)
{
    const uint8_t *h = r->buf + r->pos;
    size_t i;
    size_t k;
    size_t n;
    aacmm_status_t st;
    memset(p, 0, sizeof *p);
    if (r->len - r->pos < AACMM_PARAM_SET_HEADER_BYTES ||
        r->len - r->pos != param_set_len_raw(h)) {
        rd_fail(r, AACMM_ERR_LENGTH);
        return;
    }
    if (!param_header_ok(h)) {
        rd_fail(r, AACMM_ERR_RANGE);
        return;
    }
    n = h[0];
    p->arm.shape.joints = h[0];
    p->arm.shape.tip = h[1];
    for (i = 0; i < n; i++) {
        p->arm.shape.convention[i] = (uint8_t)((h[2] >> i) & 1u);
        p->arm.shape.beta[i] = (uint8_t)((h[3] >> i) & 1u);
    }
    for (i = 0; i < n; i++) {
        p->err.harmonics[i] = (uint8_t)((hdr_em(h) >> (4u * i)) & 0xFu);
    }
    p->err.thermal = (uint8_t)((hdr_em(h) >> AACMM_PARAM_THERMAL_BIT) & 1u);
    r->pos += AACMM_PARAM_SET_HEADER_BYTES;
    rd_f64_array(r, p->arm.theta_offset_rad, n);
    rd_f64_array(r, p->arm.alpha_rad, n);
    rd_f64_array(r, p->arm.d_mm, n);
    rd_f64_array(r, p->arm.a_mm, n);
    for (i = 0; i < n; i++) {
        if (p->arm.shape.beta[i] != 0u) {
            p->arm.beta_rad[i] = rd_f64(r);
        }
    }
    if (p->arm.shape.tip == (uint8_t)AACMM_TIP_XYZ) {
        rd_f64_array(r, p->arm.tip_mm, 3u);
    } else {
        p->arm.tip_mm[2] = rd_f64(r);
    }
    p->enc.joints = (uint8_t)n;
    for (i = 0; i < n; i++) {
        p->enc.counts_per_rev[i] = (uint64_t)rd_u32(r) + 1u;
    }
    for (i = 0; i < n; i++) {
        p->enc.zero_offset_counts[i] = rd_u32(r);
    }
    for (i = 0; i < n; i++) {
        uint8_t b = rd_u8(r);
        p->enc.direction[i] = (b == 0xFFu) ? (int8_t)-1 : (b == 1u ? (int8_t)1 : (int8_t)0);
    }
    for (i = 0; i < n; i++) {
        for (k = 0; k < p->err.harmonics[i]; k++) {
            p->err.harm_cos[i][k] = rd_i16(r);
            p->err.harm_sin[i][k] = rd_i16(r);
        }
    }
    if (p->err.thermal != 0u) {
        for (i = 0; i < n; i++) {
            p->err.cte[i] = rd_i16(r);
        }
        p->err.ref_temp = rd_i16(r);
    }
    if (r->err != AACMM_OK) {
        return;
    }
    if (p->err.thermal != 0u && !ref_temp_ok(p->err.ref_temp)) {
        rd_fail(r, AACMM_ERR_RANGE);
        return;
    }
    st = enc_check(&p->enc);
    if (st != AACMM_OK) {
        rd_fail(r, st);
    }
}

static void wr_jacobian(wr_t *w, const float *jac, size_t p)
{
    size_t i;
    for (i = 0; i < 3u * p; i++) {
        wr_f32(w, jac[i]);
    }
}

static void rd_jacobian(rd_t *r, float *jac, size_t p)
{
    size_t i;
    for (i = 0; i < 3u * p; i++) {
        jac[i] = rd_f32(r);
    }
    for (; i < (size_t)AACMM_JAC_SIZE_MAX; i++) {
        jac[i] = 0.0f;
    }
}

/* N in 4..7 and P a parameter count some N-joint shape has: 4N+1 .. 5N+2. */
static int joints_params_ok(unsigned n, unsigned p)
{
    return n >= (unsigned)AACMM_JOINTS_MIN && n <= (unsigned)AACMM_JOINTS_MAX &&
           p >= 4u * n + 1u && p <= 5u * n + 2u;
}

static int joints_ok(unsigned n)
{
    return n >= (unsigned)AACMM_JOINTS_MIN && n <= (unsigned)AACMM_JOINTS_MAX;
}

static void wr_content(wr_t *w, uint8_t content)
{
    if ((content & (uint8_t)~AACMM_CONTENT_KNOWN) != 0u) {
        wr_fail(w, AACMM_ERR_RANGE);
    }
    wr_u8(w, content);
}

static uint8_t rd_content(rd_t *r)
{
    uint8_t c = rd_u8(r);
    if ((c & (uint8_t)~AACMM_CONTENT_KNOWN) != 0u) {
        rd_fail(r, AACMM_ERR_RANGE);
    }
    return c;
}

static void wr_sample(wr_t *w, const aacmm_sample_t *s)
{
    size_t i;
    /* N 7, P 37 with temperatures and Jacobian would not fit a body. */
    if (!joints_params_ok(s->joints, s->params) ||
        AACMM_SAMPLE_BYTES((size_t)s->joints, (size_t)s->params, s->content) >
            AACMM_SAMPLE_MAX_BYTES) {
        wr_fail(w, AACMM_ERR_RANGE);
        return;
    }
    wr_u32(w, s->seq);
    wr_u64(w, s->timestamp_us);
    for (i = 0; i < 3u; i++) {
        wr_u32(w, (uint32_t)s->point_100nm[i]);
    }
    wr_u32(w, s->status);
    wr_content(w, s->content);
    wr_u8(w, s->joints);
    wr_u8(w, s->params);
    for (i = 0; i < s->joints; i++) {
        wr_u32(w, s->counts[i]);
    }
    if ((s->content & AACMM_CONTENT_TEMPERATURES) != 0u) {
        for (i = 0; i < s->joints; i++) {
            wr_i16(w, s->temp[i]);
        }
    }
    if ((s->content & AACMM_CONTENT_JACOBIAN) != 0u) {
        wr_jacobian(w, s->jacobian, s->params);
    }
}

static int32_t u32_to_i32(uint32_t u)
{
    /* Two's complement reinterpretation without implementation-defined casts. */
    if (u <= 0x7FFFFFFFu) {
        return (int32_t)u;
    }
    return (int32_t)(u - 0x80000000u) - (int32_t)0x40000000 - (int32_t)0x40000000;
}

static void rd_sample(rd_t *r, aacmm_sample_t *s)
{
    size_t i;
    s->seq = rd_u32(r);
    s->timestamp_us = rd_u64(r);
    for (i = 0; i < 3u; i++) {
        s->point_100nm[i] = u32_to_i32(rd_u32(r));
    }
    s->status = rd_u32(r);
    s->content = rd_content(r);
    s->joints = rd_u8(r);
    s->params = rd_u8(r);
    if (r->err == AACMM_OK && !joints_params_ok(s->joints, s->params)) {
        rd_fail(r, AACMM_ERR_RANGE);
        return;
    }
    memset(s->counts, 0, sizeof s->counts);
    memset(s->temp, 0, sizeof s->temp);
    for (i = 0; i < s->joints && r->err == AACMM_OK; i++) {
        s->counts[i] = rd_u32(r);
    }
    if ((s->content & AACMM_CONTENT_TEMPERATURES) != 0u) {
        for (i = 0; i < s->joints; i++) {
            s->temp[i] = rd_i16(r); /* any i16: the device sends what the sensor said */
        }
    }
    if ((s->content & AACMM_CONTENT_JACOBIAN) != 0u) {
        rd_jacobian(r, s->jacobian, s->params);
    } else {
        memset(s->jacobian, 0, sizeof s->jacobian);
    }
}

static int diag_in_range(const aacmm_msg_diag_t *d)
{
    size_t i;
    if (d->storage_kind > AACMM_STORAGE_KIND_MAX ||
        (d->storage_flags & (uint8_t)~AACMM_STORAGE_FLAGS_KNOWN) != 0u ||
        d->slot_state[0] > AACMM_SLOT_STATE_MAX || d->slot_state[1] > AACMM_SLOT_STATE_MAX ||
        d->reset_cause > AACMM_RESET_CAUSE_MAX || !joints_ok(d->joints)) {
        return 0;
    }
    for (i = 0; i < d->joints; i++) {
        const aacmm_diag_joint_t *j = &d->joint[i];
        if (j->interface > AACMM_ENC_INTERFACE_MAX || j->bits > 32u ||
            j->last_fault > AACMM_ENC_FAULT_MAX) {
            return 0;
        }
    }
    return 1;
}

static void wr_diag(wr_t *w, const aacmm_msg_diag_t *d)
{
    size_t i;
    if (!diag_in_range(d)) {
        wr_fail(w, AACMM_ERR_RANGE);
        return;
    }
    wr_u8(w, d->storage_kind);
    wr_u8(w, d->storage_flags);
    wr_u8(w, d->slot_state[0]);
    wr_u8(w, d->slot_state[1]);
    wr_u32(w, d->slot_generation[0]);
    wr_u32(w, d->slot_generation[1]);
    wr_u32(w, d->storage_errors);
    wr_u32(w, d->storage_bad_records);
    wr_u8(w, d->reset_cause);
    wr_u32(w, d->reset_raw);
    wr_u32(w, d->fault_pc);
    wr_u32(w, d->boot_count);
    wr_u16(w, d->watchdog_ms);
    wr_u64(w, d->uptime_us);
    wr_u32(w, d->encoder_faults);
    wr_u32(w, d->serial_frames_bad);
    wr_u32(w, d->samples_dropped);
    wr_u32(w, d->samples_late);
    wr_u8(w, d->joints);
    for (i = 0; i < d->joints; i++) {
        const aacmm_diag_joint_t *j = &d->joint[i];
        wr_u8(w, j->interface);
        wr_u8(w, j->bits);
        wr_u8(w, j->last_fault);
        wr_u32(w, j->faults);
        wr_u32(w, j->warnings);
    }
    wr_u32(w, d->temp_faults);
}

static void rd_diag(rd_t *r, aacmm_msg_diag_t *d)
{
    size_t i;
    d->storage_kind = rd_u8(r);
    d->storage_flags = rd_u8(r);
    d->slot_state[0] = rd_u8(r);
    d->slot_state[1] = rd_u8(r);
    d->slot_generation[0] = rd_u32(r);
    d->slot_generation[1] = rd_u32(r);
    d->storage_errors = rd_u32(r);
    d->storage_bad_records = rd_u32(r);
    d->reset_cause = rd_u8(r);
    d->reset_raw = rd_u32(r);
    d->fault_pc = rd_u32(r);
    d->boot_count = rd_u32(r);
    d->watchdog_ms = rd_u16(r);
    d->uptime_us = rd_u64(r);
    d->encoder_faults = rd_u32(r);
    d->serial_frames_bad = rd_u32(r);
    d->samples_dropped = rd_u32(r);
    d->samples_late = rd_u32(r);
    d->joints = rd_u8(r);
    memset(d->joint, 0, sizeof d->joint);
    for (i = 0; i < d->joints && i < (size_t)AACMM_JOINTS_MAX; i++) {
        aacmm_diag_joint_t *j = &d->joint[i];
        j->interface = rd_u8(r);
        j->bits = rd_u8(r);
        j->last_fault = rd_u8(r);
        j->faults = rd_u32(r);
        j->warnings = rd_u32(r);
    }
    d->temp_faults = rd_u32(r);
    if (r->err == AACMM_OK && !diag_in_range(d)) {
        rd_fail(r, AACMM_ERR_RANGE);
    }
}

/* ---- public API -------------------------------------------------------- */

int aacmm_msg_type_known(uint8_t type)
{
    switch (type) {
    case AACMM_MSG_PING_REQ:
    case AACMM_MSG_INFO_REQ:
    case AACMM_MSG_GET_PARAMS_REQ:
    case AACMM_MSG_SET_PARAMS_REQ:
    case AACMM_MSG_SAVE_PARAMS_REQ:
    case AACMM_MSG_RESTORE_DEFAULTS_REQ:
    case AACMM_MSG_MEASURE_REQ:
    case AACMM_MSG_COMPUTE_REQ:
    case AACMM_MSG_STREAM_START_REQ:
    case AACMM_MSG_STREAM_STOP_REQ:
    case AACMM_MSG_DIAG_REQ:
    case AACMM_MSG_SAMPLE_EVT:
    case AACMM_MSG_TRIGGER_EVT:
    case AACMM_MSG_PING_RSP:
    case AACMM_MSG_INFO_RSP:
    case AACMM_MSG_GET_PARAMS_RSP:
    case AACMM_MSG_SET_PARAMS_RSP:
    case AACMM_MSG_SAVE_PARAMS_RSP:
    case AACMM_MSG_RESTORE_DEFAULTS_RSP:
    case AACMM_MSG_MEASURE_RSP:
    case AACMM_MSG_COMPUTE_RSP:
    case AACMM_MSG_STREAM_START_RSP:
    case AACMM_MSG_STREAM_STOP_RSP:
    case AACMM_MSG_DIAG_RSP:
    case AACMM_MSG_ERROR_RSP:
        return 1;
    default:
        return 0;
    }
}

/* Length of a sample from its raw bytes at s (n bytes available). */
static size_t sample_len_raw(const uint8_t *s, size_t n)
{
    if (n < AACMM_SAMPLE_BASE_BYTES) {
        return AACMM_SAMPLE_BASE_BYTES;
    }
    return AACMM_SAMPLE_BYTES((size_t)s[29], (size_t)s[30], s[28]); /* raw content: its bits 0, 1 */
}

size_t aacmm_msg_payload_len(uint8_t type, const uint8_t *payload, size_t len)
{
    if (payload == NULL) {
        len = 0u;
    }
    switch (type) {
    case AACMM_MSG_PING_REQ:
    case AACMM_MSG_PING_RSP:
    case AACMM_MSG_SET_PARAMS_RSP:
    case AACMM_MSG_SAVE_PARAMS_RSP:
    case AACMM_MSG_RESTORE_DEFAULTS_RSP:
        return 4u;
    case AACMM_MSG_INFO_RSP:
        return AACMM_INFO_BYTES;
    case AACMM_MSG_SET_PARAMS_REQ:
    case AACMM_MSG_GET_PARAMS_RSP:
        return len < AACMM_PARAM_SET_HEADER_BYTES ? AACMM_PARAM_SET_HEADER_BYTES
                                                  : param_set_len_raw(payload);
    case AACMM_MSG_MEASURE_REQ:
        return 1u;
    case AACMM_MSG_COMPUTE_REQ:
        return len < 2u ? 2u : AACMM_COMPUTE_REQ_BYTES((size_t)payload[1], payload[0]);
    case AACMM_MSG_STREAM_START_REQ:
    case AACMM_MSG_STREAM_START_RSP:
    case AACMM_MSG_ERROR_RSP:
        return 3u;
    case AACMM_MSG_MEASURE_RSP:
    case AACMM_MSG_SAMPLE_EVT:
        return sample_len_raw(payload, len);
    case AACMM_MSG_TRIGGER_EVT:
        if (len < AACMM_TRIGGER_EXTRA_BYTES) {
            return AACMM_TRIGGER_EXTRA_BYTES + AACMM_SAMPLE_BASE_BYTES;
        }
        return AACMM_TRIGGER_EXTRA_BYTES +
               sample_len_raw(payload + AACMM_TRIGGER_EXTRA_BYTES, len - AACMM_TRIGGER_EXTRA_BYTES);
    case AACMM_MSG_COMPUTE_RSP:
        return len < AACMM_COMPUTE_RSP_BASE_BYTES
                   ? AACMM_COMPUTE_RSP_BASE_BYTES
                   : AACMM_COMPUTE_RSP_BYTES((size_t)payload[29],
                                             (payload[28] & AACMM_CONTENT_JACOBIAN) != 0u);
    case AACMM_MSG_DIAG_RSP:
        return len < AACMM_DIAG_BASE_BYTES ? AACMM_DIAG_BASE_BYTES
                                           : AACMM_DIAG_BYTES((size_t)payload[59]);
    default:
        return 0u;
    }
}

aacmm_status_t aacmm_msg_encode(const aacmm_msg_t *msg, uint8_t *out, size_t out_cap,
                                size_t *out_len)
{
    wr_t w;
    size_t i;
    if (msg == NULL || out == NULL || out_len == NULL) {
        return AACMM_ERR_NULL;
    }
    *out_len = 0u;
    if (!aacmm_msg_type_known(msg->type)) {
        return AACMM_ERR_UNKNOWN_TYPE;
    }
    w.buf = out;
    w.cap = out_cap;
    w.pos = 0u;
    w.err = AACMM_OK;
    w.crc = 0u;
    wr_u8(&w, (uint8_t)AACMM_PROTO_VERSION);
    wr_u8(&w, msg->type);
    wr_u8(&w, msg->seq);

    switch (msg->type) {
    case AACMM_MSG_PING_REQ:
    case AACMM_MSG_PING_RSP:
        wr_u32(&w, msg->u.ping.token);
        break;
    case AACMM_MSG_INFO_RSP: {
        const aacmm_msg_info_t *in = &msg->u.info;
        if (in->param_source > AACMM_PARAM_SOURCE_MAX ||
            in->storage_state > AACMM_STORAGE_STATE_MAX || in->can_node_id > 15u ||
            !joints_params_ok(in->joints, in->params)) {
            wr_fail(&w, AACMM_ERR_RANGE);
        }
        wr_u16(&w, in->protocol_version);
        wr_u8(&w, in->fw_major);
        wr_u8(&w, in->fw_minor);
        wr_u16(&w, in->fw_patch);
        wr_u32(&w, in->build_flags);
        wr_u32(&w, in->param_crc32);
        wr_u8(&w, in->param_source);
        wr_u8(&w, in->storage_state);
        wr_u16(&w, in->max_body_bytes);
        wr_u32(&w, in->serial_number);
        wr_u8(&w, in->can_node_id);
        wr_u8(&w, in->joints);
        wr_u8(&w, in->params);
        break;
    }
    case AACMM_MSG_SET_PARAMS_REQ:
    case AACMM_MSG_GET_PARAMS_RSP:
        wr_params(&w, &msg->u.params);
        break;
    case AACMM_MSG_SET_PARAMS_RSP:
    case AACMM_MSG_SAVE_PARAMS_RSP:
    case AACMM_MSG_RESTORE_DEFAULTS_RSP:
        wr_u32(&w, msg->u.param_crc.param_crc32);
        break;
    case AACMM_MSG_MEASURE_REQ:
        wr_content(&w, msg->u.measure.content);
        break;
    case AACMM_MSG_COMPUTE_REQ:
        if (!joints_ok(msg->u.compute_req.joints)) {
            wr_fail(&w, AACMM_ERR_RANGE);
            break;
        }
        wr_content(&w, msg->u.compute_req.content);
        wr_u8(&w, msg->u.compute_req.joints);
        for (i = 0; i < msg->u.compute_req.joints; i++) {
            wr_u32(&w, msg->u.compute_req.counts[i]);
        }
        if ((msg->u.compute_req.content & AACMM_CONTENT_TEMPERATURES) != 0u) {
            for (i = 0; i < msg->u.compute_req.joints; i++) {
                if (!ref_temp_ok(msg->u.compute_req.temp[i])) {
                    wr_fail(&w, AACMM_ERR_RANGE);
                }
                wr_i16(&w, msg->u.compute_req.temp[i]);
            }
        }
        break;
    case AACMM_MSG_STREAM_START_REQ:
    case AACMM_MSG_STREAM_START_RSP:
        if (msg->u.stream.rate_hz < AACMM_STREAM_RATE_MIN_HZ ||
            msg->u.stream.rate_hz > AACMM_STREAM_RATE_MAX_HZ) {
            wr_fail(&w, AACMM_ERR_RANGE);
        }
        wr_u16(&w, msg->u.stream.rate_hz);
        wr_content(&w, msg->u.stream.content);
        break;
    case AACMM_MSG_MEASURE_RSP:
    case AACMM_MSG_SAMPLE_EVT:
        wr_sample(&w, &msg->u.sample);
        break;
    case AACMM_MSG_TRIGGER_EVT:
        if (msg->u.trigger.pressed > 1u) {
            wr_fail(&w, AACMM_ERR_RANGE);
        }
        wr_u8(&w, msg->u.trigger.button);
        wr_u8(&w, msg->u.trigger.pressed);
        wr_sample(&w, &msg->u.trigger.sample);
        break;
    case AACMM_MSG_COMPUTE_RSP: {
        const aacmm_msg_compute_rsp_t *c = &msg->u.compute_rsp;
        wr_u32(&w, c->status);
        for (i = 0; i < 3u; i++) {
            wr_f64(&w, c->point_mm[i]);
        }
        if (c->params < 4u * (unsigned)AACMM_JOINTS_MIN + 1u ||
            c->params > (unsigned)AACMM_PARAMS_MAX) {
            wr_fail(&w, AACMM_ERR_RANGE);
            break;
        }
        wr_content(&w, c->content);
        wr_u8(&w, c->params);
        if ((c->content & AACMM_CONTENT_JACOBIAN) != 0u) {
            wr_jacobian(&w, c->jacobian, c->params);
        }
        break;
    }
    case AACMM_MSG_DIAG_RSP:
        wr_diag(&w, &msg->u.diag);
        break;
    case AACMM_MSG_ERROR_RSP:
        if (msg->u.error.status >= 0) {
            wr_fail(&w, AACMM_ERR_RANGE);
        }
        wr_u16(&w, (uint16_t)msg->u.error.status);
        wr_u8(&w, msg->u.error.request_type);
        break;
    default: /* INFO_REQ, GET/SAVE_PARAMS_REQ, RESTORE_DEFAULTS_REQ, STREAM_STOP_*, DIAG_REQ */
        break;
    }
    if (w.err != AACMM_OK) {
        return w.err;
    }
    if (w.pos > AACMM_PROTO_MAX_BODY) {
        return AACMM_ERR_LENGTH; /* cannot happen: every layout fits (AACMM_SAMPLE_MAX_BYTES) */
    }
    *out_len = w.pos;
    return AACMM_OK;
}

aacmm_status_t aacmm_msg_decode(const uint8_t *body, size_t len, aacmm_msg_t *msg)
{
    rd_t r;
    size_t i;
    if (body == NULL || msg == NULL) {
        return AACMM_ERR_NULL;
    }
    msg->type = 0u;
    msg->seq = 0u;
    if (len < AACMM_PROTO_HEADER_BYTES) {
        return AACMM_ERR_LENGTH;
    }
    msg->type = body[1];
    msg->seq = body[2];
    if (len > AACMM_PROTO_MAX_BODY) {
        return AACMM_ERR_LENGTH;
    }
    if (body[0] != AACMM_PROTO_VERSION) {
        return AACMM_ERR_VERSION;
    }
    if (!aacmm_msg_type_known(msg->type)) {
        return AACMM_ERR_UNKNOWN_TYPE;
    }
    /* The payload's own bytes (content, N, P, ...) fix its length. */
    if (len - AACMM_PROTO_HEADER_BYTES !=
            aacmm_msg_payload_len(msg->type, body + AACMM_PROTO_HEADER_BYTES,
                                  len - AACMM_PROTO_HEADER_BYTES)) {
        return AACMM_ERR_LENGTH;
    }

    r.buf = body;
    r.len = len;
    r.pos = AACMM_PROTO_HEADER_BYTES;
    r.err = AACMM_OK;
    switch (msg->type) {
    case AACMM_MSG_PING_REQ:
    case AACMM_MSG_PING_RSP:
        msg->u.ping.token = rd_u32(&r);
        break;
    case AACMM_MSG_INFO_RSP: {
        aacmm_msg_info_t *in = &msg->u.info;
        in->protocol_version = rd_u16(&r);
        in->fw_major = rd_u8(&r);
        in->fw_minor = rd_u8(&r);
        in->fw_patch = rd_u16(&r);
        in->build_flags = rd_u32(&r);
        in->param_crc32 = rd_u32(&r);
        in->param_source = rd_u8(&r);
        in->storage_state = rd_u8(&r);
        in->max_body_bytes = rd_u16(&r);
        in->serial_number = rd_u32(&r);
        in->can_node_id = rd_u8(&r);
        in->joints = rd_u8(&r);
        in->params = rd_u8(&r);
        if (in->param_source > AACMM_PARAM_SOURCE_MAX ||
            in->storage_state > AACMM_STORAGE_STATE_MAX || in->can_node_id > 15u ||
            !joints_params_ok(in->joints, in->params)) {
            rd_fail(&r, AACMM_ERR_RANGE);
        }
        break;
    }
    case AACMM_MSG_SET_PARAMS_REQ:
    case AACMM_MSG_GET_PARAMS_RSP:
        rd_params(&r, &msg->u.params);
        break;
    case AACMM_MSG_SET_PARAMS_RSP:
    case AACMM_MSG_SAVE_PARAMS_RSP:
    case AACMM_MSG_RESTORE_DEFAULTS_RSP:
        msg->u.param_crc.param_crc32 = rd_u32(&r);
        break;
    case AACMM_MSG_MEASURE_REQ:
        msg->u.measure.content = rd_content(&r);
        break;
    case AACMM_MSG_COMPUTE_REQ:
        msg->u.compute_req.content = rd_content(&r);
        msg->u.compute_req.joints = rd_u8(&r);
        memset(msg->u.compute_req.counts, 0, sizeof msg->u.compute_req.counts);
        memset(msg->u.compute_req.temp, 0, sizeof msg->u.compute_req.temp);
        if (r.err == AACMM_OK && !joints_ok(msg->u.compute_req.joints)) {
            rd_fail(&r, AACMM_ERR_RANGE);
            break;
        }
        for (i = 0; i < msg->u.compute_req.joints; i++) {
            msg->u.compute_req.counts[i] = rd_u32(&r);
        }
        if ((msg->u.compute_req.content & AACMM_CONTENT_TEMPERATURES) != 0u) {
            for (i = 0; i < msg->u.compute_req.joints; i++) {
                msg->u.compute_req.temp[i] = rd_i16(&r);
                if (!ref_temp_ok(msg->u.compute_req.temp[i])) {
                    rd_fail(&r, AACMM_ERR_RANGE); /* AACMM_TEMP_NONE too */
                }
            }
        }
        break;
    case AACMM_MSG_STREAM_START_REQ:
    case AACMM_MSG_STREAM_START_RSP:
        msg->u.stream.rate_hz = rd_u16(&r);
        msg->u.stream.content = rd_content(&r);
        if (msg->u.stream.rate_hz < AACMM_STREAM_RATE_MIN_HZ ||
            msg->u.stream.rate_hz > AACMM_STREAM_RATE_MAX_HZ) {
            rd_fail(&r, AACMM_ERR_RANGE);
        }
        break;
    case AACMM_MSG_MEASURE_RSP:
    case AACMM_MSG_SAMPLE_EVT:
        rd_sample(&r, &msg->u.sample);
        break;
    case AACMM_MSG_TRIGGER_EVT:
        msg->u.trigger.button = rd_u8(&r);
        msg->u.trigger.pressed = rd_u8(&r);
        if (msg->u.trigger.pressed > 1u) {
            rd_fail(&r, AACMM_ERR_RANGE);
        }
        rd_sample(&r, &msg->u.trigger.sample);
        break;
    case AACMM_MSG_COMPUTE_RSP: {
        aacmm_msg_compute_rsp_t *c = &msg->u.compute_rsp;
        c->status = rd_u32(&r);
        for (i = 0; i < 3u; i++) {
            c->point_mm[i] = rd_f64(&r);
        }
        c->content = rd_content(&r);
        c->params = rd_u8(&r);
        if (r.err == AACMM_OK && (c->params < 4u * (unsigned)AACMM_JOINTS_MIN + 1u ||
                                  c->params > (unsigned)AACMM_PARAMS_MAX)) {
            rd_fail(&r, AACMM_ERR_RANGE);
            break;
        }
        if ((c->content & AACMM_CONTENT_JACOBIAN) != 0u) {
            rd_jacobian(&r, c->jacobian, c->params);
        } else {
            memset(c->jacobian, 0, sizeof c->jacobian);
        }
        break;
    }
    case AACMM_MSG_DIAG_RSP:
        rd_diag(&r, &msg->u.diag);
        break;
    case AACMM_MSG_ERROR_RSP: {
        uint16_t raw = rd_u16(&r);
        int32_t v = (raw >= 0x8000u) ? (int32_t)raw - 0x10000 : (int32_t)raw;
        msg->u.error.status = (int16_t)v;
        msg->u.error.request_type = rd_u8(&r);
        if (v >= 0) {
            rd_fail(&r, AACMM_ERR_RANGE);
        }
        break;
    }
    default:
        break;
    }
    if (r.err != AACMM_OK) {
        return r.err;
    }
    if (r.pos != r.len) {
        return AACMM_ERR_LENGTH; /* unreachable: lengths were checked above */
    }
    return AACMM_OK;
}

aacmm_status_t aacmm_msg_decode_counted(const uint8_t *body, size_t len, aacmm_msg_t *msg,
                                        aacmm_msg_stats_t *stats)
{
    aacmm_status_t st = aacmm_msg_decode(body, len, msg);
    if (stats != NULL) {
        switch (st) {
        case AACMM_OK: stats->ok++; break;
        case AACMM_ERR_LENGTH: stats->length++; break;
        case AACMM_ERR_VERSION: stats->version++; break;
        case AACMM_ERR_UNKNOWN_TYPE: stats->unknown_type++; break;
        case AACMM_ERR_RANGE: stats->range++; break;
        case AACMM_ERR_NOT_FINITE: stats->not_finite++; break;
        default: stats->other++; break;
        }
    }
    return st;
}

uint8_t aacmm_msg_response_type(uint8_t request_type)
{
    if (request_type >= AACMM_MSG_PING_REQ && request_type <= AACMM_MSG_DIAG_REQ) {
        return (uint8_t)(request_type | AACMM_MSG_RESPONSE_BIT);
    }
    return 0u;
}

aacmm_status_t aacmm_msg_make_error(aacmm_msg_t *msg, uint8_t seq, uint8_t request_type,
                                    aacmm_status_t status)
{
    if (msg == NULL) {
        return AACMM_ERR_NULL;
    }
    if ((int)status >= 0) { /* every aacmm_status_t fits the i16 field */
        return AACMM_ERR_RANGE;
    }
    msg->type = AACMM_MSG_ERROR_RSP;
    msg->seq = seq;
    msg->u.error.status = (int16_t)status;
    msg->u.error.request_type = request_type;
    return AACMM_OK;
}

aacmm_status_t aacmm_msg_encode_frame(const aacmm_msg_t *msg, uint8_t *scratch,
                                      size_t scratch_cap, uint8_t *out, size_t out_cap,
                                      size_t *out_len)
{
    size_t body_len = 0u;
    aacmm_status_t st;
    if (out_len == NULL) {
        return AACMM_ERR_NULL;
    }
    *out_len = 0u;
    st = aacmm_msg_encode(msg, scratch, scratch_cap, &body_len);
    if (st != AACMM_OK) {
        return st;
    }
    return aacmm_frame_encode(scratch, body_len, out, out_cap, out_len);
}

aacmm_status_t aacmm_param_set_encode(const aacmm_param_set_t *set, uint8_t *out, size_t out_cap,
                                      size_t *out_len)
{
    wr_t w;
    if (set == NULL || out == NULL || out_len == NULL) {
        return AACMM_ERR_NULL;
    }
    *out_len = 0u;
    w.buf = out;
    w.cap = out_cap;
    w.pos = 0u;
    w.err = AACMM_OK;
    w.crc = 0u;
    wr_params(&w, set);
    if (w.err == AACMM_OK) {
        *out_len = w.pos;
    }
    return w.err;
}

aacmm_status_t aacmm_param_set_decode(const uint8_t *in, size_t len, aacmm_param_set_t *set)
{
    rd_t r;
    if (in == NULL || set == NULL) {
        return AACMM_ERR_NULL;
    }
    r.buf = in;
    r.len = len;
    r.pos = 0u;
    r.err = AACMM_OK;
    rd_params(&r, set);
    return r.err;
}

aacmm_status_t aacmm_param_set_crc32(const aacmm_param_set_t *set, uint32_t *crc32)
{
    wr_t w; /* CRC-only writer: no parameter-set buffer on the stack */
    if (crc32 == NULL || set == NULL) {
        return AACMM_ERR_NULL;
    }
    *crc32 = 0u;
    w.buf = NULL;
    w.cap = 0u;
    w.pos = 0u;
    w.err = AACMM_OK;
    w.crc = AACMM_CRC32_INIT;
    wr_params(&w, set);
    if (w.err != AACMM_OK) {
        return w.err;
    }
    *crc32 = aacmm_crc32_final(w.crc);
    return AACMM_OK;
}

int32_t aacmm_point_mm_to_wire(double mm, int *clipped)
{
    double units = mm * 1e4;
    int clip = 0;
    int32_t v;
    if (!(units >= 0.0) && !(units < 0.0)) { /* NaN */
        clip = 1;
        v = 0;
    } else if (units >= 2147483647.0) {
        clip = (units > 2147483647.0) ? 1 : 0;
        v = INT32_MAX;
    } else if (units <= -2147483648.0) {
        clip = (units < -2147483648.0) ? 1 : 0;
        v = INT32_MIN;
    } else {
        double r = (units >= 0.0) ? units + 0.5 : units - 0.5;
        v = (int32_t)r; /* truncation toward zero after the half offset: round half away */
    }
    if (clipped != NULL) {
        *clipped = clip;
    }
    return v;
}
