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

static void wr_params(wr_t *w, const aacmm_param_set_t *p)
{
    size_t i;
    aacmm_status_t st;
    wr_f64_array(w, p->kin.theta_offset_rad, AACMM_JOINTS);
    wr_f64_array(w, p->kin.alpha_rad, AACMM_JOINTS);
    wr_f64_array(w, p->kin.d_mm, AACMM_JOINTS);
    wr_f64_array(w, p->kin.a_mm, AACMM_JOINTS);
    wr_f64(w, p->kin.l_mm);
    for (i = 0; i < AACMM_JOINTS; i++) {
        wr_u64(w, p->enc.counts_per_rev[i]);
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        wr_u32(w, p->enc.zero_offset_counts[i]);
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        wr_u8(w, (uint8_t)p->enc.direction[i]);
    }
    st = aacmm_encoder_validate(&p->enc);
    if (st != AACMM_OK) {
        wr_fail(w, st);
    }
}

static void rd_params(rd_t *r, aacmm_param_set_t *p)
{
    size_t i;
    aacmm_status_t st;
    rd_f64_array(r, p->kin.theta_offset_rad, AACMM_JOINTS);
    rd_f64_array(r, p->kin.alpha_rad, AACMM_JOINTS);
    rd_f64_array(r, p->kin.d_mm, AACMM_JOINTS);
    rd_f64_array(r, p->kin.a_mm, AACMM_JOINTS);
    p->kin.l_mm = rd_f64(r);
    for (i = 0; i < AACMM_JOINTS; i++) {
        p->enc.counts_per_rev[i] = rd_u64(r);
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        p->enc.zero_offset_counts[i] = rd_u32(r);
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        uint8_t b = rd_u8(r);
        p->enc.direction[i] = (b == 0xFFu) ? (int8_t)-1 : (b == 1u ? (int8_t)1 : (int8_t)0);
    }
    st = aacmm_encoder_validate(&p->enc);
    if (st != AACMM_OK) {
        rd_fail(r, st);
    }
}

static void wr_jacobian(wr_t *w, const float *jac)
{
    size_t i;
    for (i = 0; i < AACMM_JAC_SIZE; i++) {
        wr_f32(w, jac[i]);
    }
}

static void rd_jacobian(rd_t *r, float *jac)
{
    size_t i;
    for (i = 0; i < AACMM_JAC_SIZE; i++) {
        jac[i] = rd_f32(r);
    }
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
    wr_u32(w, s->seq);
    wr_u64(w, s->timestamp_us);
    for (i = 0; i < AACMM_JOINTS; i++) {
        wr_u32(w, s->counts[i]);
    }
    for (i = 0; i < 3u; i++) {
        wr_u32(w, (uint32_t)s->point_100nm[i]);
    }
    wr_u32(w, s->status);
    wr_content(w, s->content);
    if ((s->content & AACMM_CONTENT_JACOBIAN) != 0u) {
        wr_jacobian(w, s->jacobian);
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
    for (i = 0; i < AACMM_JOINTS; i++) {
        s->counts[i] = rd_u32(r);
    }
    for (i = 0; i < 3u; i++) {
        s->point_100nm[i] = u32_to_i32(rd_u32(r));
    }
    s->status = rd_u32(r);
    s->content = rd_content(r);
    if ((s->content & AACMM_CONTENT_JACOBIAN) != 0u) {
        rd_jacobian(r, s->jacobian);
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
        d->reset_cause > AACMM_RESET_CAUSE_MAX) {
        return 0;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        const aacmm_diag_joint_t *j = &d->joints[i];
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
    for (i = 0; i < AACMM_JOINTS; i++) {
        const aacmm_diag_joint_t *j = &d->joints[i];
        wr_u8(w, j->interface);
        wr_u8(w, j->bits);
        wr_u8(w, j->last_fault);
        wr_u32(w, j->faults);
        wr_u32(w, j->warnings);
    }
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
    for (i = 0; i < AACMM_JOINTS; i++) {
        aacmm_diag_joint_t *j = &d->joints[i];
        j->interface = rd_u8(r);
        j->bits = rd_u8(r);
        j->last_fault = rd_u8(r);
        j->faults = rd_u32(r);
        j->warnings = rd_u32(r);
    }
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

size_t aacmm_msg_payload_len(uint8_t type, uint8_t content)
{
    size_t jac = ((content & AACMM_CONTENT_JACOBIAN) != 0u) ? AACMM_JACOBIAN_BYTES : 0u;
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
        return AACMM_PARAM_SET_BYTES;
    case AACMM_MSG_MEASURE_REQ:
        return 1u;
    case AACMM_MSG_COMPUTE_REQ:
        return 1u + 4u * AACMM_JOINTS;
    case AACMM_MSG_STREAM_START_REQ:
    case AACMM_MSG_STREAM_START_RSP:
    case AACMM_MSG_ERROR_RSP:
        return 3u;
    case AACMM_MSG_MEASURE_RSP:
    case AACMM_MSG_SAMPLE_EVT:
        return AACMM_SAMPLE_BASE_BYTES + jac;
    case AACMM_MSG_TRIGGER_EVT:
        return AACMM_TRIGGER_EXTRA_BYTES + AACMM_SAMPLE_BASE_BYTES + jac;
    case AACMM_MSG_COMPUTE_RSP:
        return AACMM_COMPUTE_RSP_BASE_BYTES + jac;
    case AACMM_MSG_DIAG_RSP:
        return AACMM_DIAG_BYTES;
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
            in->storage_state > AACMM_STORAGE_STATE_MAX || in->can_node_id > 15u) {
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
        wr_content(&w, msg->u.compute_req.content);
        for (i = 0; i < AACMM_JOINTS; i++) {
            wr_u32(&w, msg->u.compute_req.counts[i]);
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
        wr_content(&w, c->content);
        if ((c->content & AACMM_CONTENT_JACOBIAN) != 0u) {
            wr_jacobian(&w, c->jacobian);
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
        return AACMM_ERR_LENGTH; /* cannot happen with version 1 layouts */
    }
    *out_len = w.pos;
    return AACMM_OK;
}

aacmm_status_t aacmm_msg_decode(const uint8_t *body, size_t len, aacmm_msg_t *msg)
{
    rd_t r;
    size_t i;
    uint8_t content = 0u;
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
    if (body[0] != AACMM_PROTO_VERSION) {
        return AACMM_ERR_VERSION;
    }
    if (!aacmm_msg_type_known(msg->type)) {
        return AACMM_ERR_UNKNOWN_TYPE;
    }
    /* The content byte (when the type has one) fixes the payload length. */
    if (msg->type == AACMM_MSG_MEASURE_RSP || msg->type == AACMM_MSG_SAMPLE_EVT) {
        if (len > AACMM_PROTO_HEADER_BYTES + AACMM_SAMPLE_BASE_BYTES - 1u) {
            content = body[AACMM_PROTO_HEADER_BYTES + AACMM_SAMPLE_BASE_BYTES - 1u];
        }
    } else if (msg->type == AACMM_MSG_TRIGGER_EVT) {
        if (len > AACMM_PROTO_HEADER_BYTES + AACMM_TRIGGER_EXTRA_BYTES +
                      AACMM_SAMPLE_BASE_BYTES - 1u) {
            content = body[AACMM_PROTO_HEADER_BYTES + AACMM_TRIGGER_EXTRA_BYTES +
                           AACMM_SAMPLE_BASE_BYTES - 1u];
        }
    } else if (msg->type == AACMM_MSG_COMPUTE_RSP) {
        if (len > AACMM_PROTO_HEADER_BYTES + AACMM_COMPUTE_RSP_BASE_BYTES - 1u) {
            content = body[AACMM_PROTO_HEADER_BYTES + AACMM_COMPUTE_RSP_BASE_BYTES - 1u];
        }
    }
    if (len - AACMM_PROTO_HEADER_BYTES != aacmm_msg_payload_len(msg->type, content)) {
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
        if (in->param_source > AACMM_PARAM_SOURCE_MAX ||
            in->storage_state > AACMM_STORAGE_STATE_MAX || in->can_node_id > 15u) {
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
        for (i = 0; i < AACMM_JOINTS; i++) {
            msg->u.compute_req.counts[i] = rd_u32(&r);
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
        if ((c->content & AACMM_CONTENT_JACOBIAN) != 0u) {
            rd_jacobian(&r, c->jacobian);
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

aacmm_status_t aacmm_param_set_encode(const aacmm_param_set_t *set, uint8_t *out, size_t out_cap)
{
    wr_t w;
    if (set == NULL || out == NULL) {
        return AACMM_ERR_NULL;
    }
    if (out_cap < AACMM_PARAM_SET_BYTES) {
        return AACMM_ERR_BUFFER;
    }
    w.buf = out;
    w.cap = out_cap;
    w.pos = 0u;
    w.err = AACMM_OK;
    w.crc = 0u;
    wr_params(&w, set);
    return w.err;
}

aacmm_status_t aacmm_param_set_decode(const uint8_t *in, size_t len, aacmm_param_set_t *set)
{
    rd_t r;
    if (in == NULL || set == NULL) {
        return AACMM_ERR_NULL;
    }
    if (len != AACMM_PARAM_SET_BYTES) {
        return AACMM_ERR_LENGTH;
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
    wr_t w; /* CRC-only writer: no 278-byte buffer on the stack */
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
