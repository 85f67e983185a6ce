/*
 * The device application (aacmm/device.h): request handling, streaming,
 * probe-button events and the two links. Portable C99: no heap, no stdio,
 * everything board-specific goes through the platform table.
 */
#include "aacmm/device.h"

#include <string.h>

#include "aacmm/crc32.h"
#include "aacmm/le_bytes.h"
#include "device_kin.h"

#define US_PER_S 1000000u
#define CAN_SAMPLE_RESERVE 8u /* CAN queue slots kept free of samples for ISO-TP */

/* ------------------------------------------------------------------------ */
/* small helpers                                                             */
/* ------------------------------------------------------------------------ */

static uint64_t now_us(const aacmm_device_t *dev)
{
    return dev->pf.time_us(dev->pf.ctx);
}

static uint32_t now_ms32(uint64_t t_us)
{
    return (uint32_t)((t_us / 1000u) & 0xFFFFFFFFu);
}

/* The serial output queue holds message bodies of samples and events, each
 * behind a header: u16 body length, u32 time queued (ms, wraps). They are
 * framed one at a time into dev->wire (the "stage") when the driver can
 * take them; a response is framed into the stage directly, so it waits for at
 * most the frame in progress, never for the queue. */
#define TXQ_HDR 6u

static size_t txq_free(const aacmm_device_serial_t *s)
{
    return s->txq_cap - s->txq_len;
}

/* Append n bytes at the tail (the caller checked the room). */
static void txq_put(aacmm_device_serial_t *s, const uint8_t *data, size_t n)
{
    size_t tail = s->txq_head + s->txq_len;
    size_t i;
    if (tail >= s->txq_cap) {
        tail -= s->txq_cap;
    }
    for (i = 0; i < n; i++) {
        s->txq[tail] = data[i];
        tail++;
        if (tail == s->txq_cap) {
            tail = 0;
        }
    }
    s->txq_len += n;
}

/* Copy n bytes from the head into out (NULL: discard) and remove them. */
static void txq_take(aacmm_device_serial_t *s, uint8_t *out, size_t n)
{
    size_t i;
    for (i = 0; i < n; i++) {
        if (out != NULL) {
            out[i] = s->txq[s->txq_head];
        }
        s->txq_head++;
        if (s->txq_head == s->txq_cap) {
            s->txq_head = 0;
        }
    }
    s->txq_len -= n;
    if (s->txq_len == 0u) {
        s->txq_head = 0u;
    }
}

/* The byte at offset k from the head. */
static uint8_t txq_peek(const aacmm_device_serial_t *s, size_t k)
{
    size_t i = s->txq_head + k;
    return s->txq[i >= s->txq_cap ? i - s->txq_cap : i];
}

static size_t canq_free(const aacmm_device_can_t *c)
{
    return AACMM_DEVICE_CAN_QUEUE - c->q_len;
}

static void canq_put(aacmm_device_can_t *c, const aacmm_can_frame_t *f)
{
    size_t tail = (c->q_head + c->q_len) % AACMM_DEVICE_CAN_QUEUE;
    c->q[tail] = *f;
    c->q_len++;
}

/* Deadline of stream sample number index. */
static uint64_t stream_deadline(const aacmm_device_stream_t *s, uint64_t index)
{
    return s->start_us + (index * US_PER_S) / s->rate_hz;
}

/* ------------------------------------------------------------------------ */
/* parameters                                                                */
/* ------------------------------------------------------------------------ */

/* A joint configuration left zero: the port has no such encoder. */
static int enc_absent(const aacmm_enc_joint_config_t *c)
{
    return c->interface == (uint8_t)AACMM_ENC_COUNTS && c->bits == 0u;
}

/* Check a parameter set completely: ranges, encoders, encodable, and the
 * backend can build a model from it (into *model). */
static aacmm_status_t check_set(const aacmm_device_t *dev, const aacmm_param_set_t *set,
                                aacmm_device_model_t *model, uint32_t *crc)
{
    aacmm_status_t st = aacmm_arm_validate_f64(&set->arm);
    if (st == AACMM_OK) {
        st = aacmm_arm_encoders_validate(&set->enc);
    }
    if (st == AACMM_OK && set->enc.joints != set->arm.shape.joints) {
        st = AACMM_ERR_RANGE;
    }
    if (st == AACMM_OK) {
        st = aacmm_param_set_crc32(set, crc);
    }
    if (st == AACMM_OK && set->arm.shape.joints > dev->frame_joints) {
        st = AACMM_ERR_UNSUPPORTED; /* more joints than the port has encoders */
    }
    if (st == AACMM_OK && set->err.thermal != 0u && dev->pf.read_temperatures == NULL) {
        st = AACMM_ERR_UNSUPPORTED; /* no link temperatures: never a point at wrong lengths */
    }
    if (st == AACMM_OK) {
        st = aacmm_device_kin_load(model, &set->arm, &set->err);
    }
    return st;
}

/* AACMM_ERR_UNSUPPORTED for a set the host asks for whose joint count the
 * port cannot serve (aacmm_device_config_t.joints_exact). */
static aacmm_status_t check_joints_served(const aacmm_device_t *dev, const aacmm_param_set_t *set)
{
    if (dev->joints_exact != 0u && set->arm.shape.joints != dev->joints_exact) {
        return AACMM_ERR_UNSUPPORTED;
    }
    return AACMM_OK;
}

/* N and P of the active arm model. */
static uint8_t active_joints(const aacmm_device_t *dev)
{
    return dev->active.arm.shape.joints;
}

static uint8_t active_params(const aacmm_device_t *dev)
{
    return (uint8_t)aacmm_shape_params(&dev->active.arm.shape);
}

/* Make *set the active set (already checked into model/crc). */
static void activate(aacmm_device_t *dev, const aacmm_param_set_t *set,
                     const aacmm_device_model_t *model, uint32_t crc, uint8_t source)
{
    dev->active = *set;
    dev->model = *model;
    dev->at_temp.valid = 0u; /* the cache belongs to the previous model */
    dev->active_crc32 = crc;
    dev->param_source = source;
}

/* ------------------------------------------------------------------------ */
/* samples                                                                   */
/* ------------------------------------------------------------------------ */

static uint8_t capture_held(const aacmm_device_t *dev)
{
    return (uint8_t)((dev->buttons >> AACMM_BUTTON_CAPTURE) & 1u);
}

/* Count a fault of joint j. */
static void joint_fault(aacmm_device_t *dev, int j, uint8_t kind)
{
    dev->joints[j].faults++;
    dev->joints[j].last_fault = kind;
}

/* Read the joints of the arm model (N) into counts[] (AACMM_JOINTS_MAX
 * entries; those past N are 0); returns the AACMM_SAMPLE_JOINT*_FAULT and
 * ENCODER_WARNING bits. A faulty joint's count is 0 (a reading beyond the
 * resolution keeps its raw value) and counted. */
static uint32_t read_joints(aacmm_device_t *dev, uint32_t counts[AACMM_JOINTS_MAX])
{
    uint32_t flags = 0u;
    int i;
    int n = (int)active_joints(dev);
    aacmm_status_t st;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        counts[i] = 0u;
    }
    if (dev->pf.read_encoder_frames != NULL) {
        st = dev->pf.read_encoder_frames(dev->pf.ctx, dev->frames);
    } else {
        st = dev->pf.read_encoders(dev->pf.ctx, counts);
    }
    if (st != AACMM_OK) {
        for (i = 0; i < AACMM_JOINTS_MAX; i++) {
            counts[i] = 0u;
        }
        for (i = 0; i < n; i++) {
            joint_fault(dev, i, (uint8_t)AACMM_ENC_FAULT_READ);
            flags |= AACMM_SAMPLE_JOINT_FAULT(i);
        }
        return flags;
    }
    for (i = n; i < AACMM_JOINTS_MAX; i++) {
        counts[i] = 0u; /* joints the arm model does not have */
    }
    for (i = 0; i < n; i++) {
        if (dev->pf.read_encoder_frames != NULL) {
            uint8_t warning = 0u;
            uint8_t fault = aacmm_enc_decode(&dev->encoders[i], &dev->frames[i], &counts[i],
                                             &warning);
            if (fault != (uint8_t)AACMM_ENC_FAULT_NONE) {
                joint_fault(dev, i, fault);
                flags |= AACMM_SAMPLE_JOINT_FAULT(i);
                continue;
            }
            if (warning != 0u) {
                dev->joints[i].warnings++;
                flags |= AACMM_SAMPLE_ENCODER_WARNING;
            }
        }
        if ((uint64_t)counts[i] >= dev->active.enc.counts_per_rev[i]) { /* raw count kept */
            joint_fault(dev, i, (uint8_t)AACMM_ENC_FAULT_RANGE);
            flags |= AACMM_SAMPLE_JOINT_FAULT(i);
        }
    }
    return flags;
}

/* Read the link temperatures (once per sample) into temp[] (AACMM_JOINTS_MAX
 * entries: the reading where its valid bit is set, even out of range, else
 * AACMM_TEMP_NONE; AACMM_TEMP_NONE past N). Returns 1 when every link of
 * the arm model is good (valid and within AACMM_REF_TEMP_MIN .. _MAX), else
 * 0 (counted in temp_faults). A platform without sensors: 1, every entry
 * AACMM_TEMP_NONE. */
static int read_temps(aacmm_device_t *dev, int16_t temp[AACMM_JOINTS_MAX])
{
    int16_t raw[AACMM_JOINTS_MAX];
    uint8_t valid = 0u;
    int n = (int)active_joints(dev);
    int good = 1;
    int i;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        temp[i] = AACMM_TEMP_NONE;
        raw[i] = AACMM_TEMP_NONE;
    }
    if (dev->pf.read_temperatures == NULL) {
        return 1;
    }
    if (dev->pf.read_temperatures(dev->pf.ctx, raw, &valid) != AACMM_OK) {
        valid = 0u; /* no reading at all: every link not valid */
    }
    for (i = 0; i < n; i++) {
        if (((valid >> i) & 1u) == 0u) {
            good = 0;
            continue;
        }
        temp[i] = raw[i];
        if (raw[i] < AACMM_REF_TEMP_MIN || raw[i] > AACMM_REF_TEMP_MAX) {
            good = 0;
        }
    }
    if (!good) {
        dev->counters.temp_faults++;
    }
    return good;
}

/* Read the encoders and the link temperatures now and fill *s (all but
 * seq). With the thermal block the point is computed at the link
 * temperatures; a sample whose temperatures are not good then has none. */
static void take_sample(aacmm_device_t *dev, uint8_t content, aacmm_sample_t *s)
{
    aacmm_status_t st = AACMM_ERR_RANGE;
    aacmm_device_point_t pt;
    uint32_t joint_flags;
    int temps_good;
    int no_temps = 0; /* the thermal block and no usable temperatures */
    int i;
    s->timestamp_us = now_us(dev);
    s->content = content;
    s->joints = active_joints(dev);
    s->params = active_params(dev);
    joint_flags = read_joints(dev, s->counts);
    temps_good = read_temps(dev, s->temp);
    s->status = joint_flags;
    if (!temps_good) {
        s->status |= AACMM_SAMPLE_TEMP_FAULT;
    }
    if ((joint_flags & AACMM_SAMPLE_JOINT_FAULTS) == 0u) {
        const aacmm_device_thermal_t *at = NULL;
        st = AACMM_OK;
        if (dev->model.thermal != 0u) {
            /* no point without good temperatures (never one at wrong lengths) */
            st = temps_good ? aacmm_device_kin_at_temperature(&dev->model, &dev->at_temp, s->temp)
                            : AACMM_ERR_RANGE;
            at = &dev->at_temp;
        }
        if (st == AACMM_OK) {
            st = aacmm_device_kin_compute(&dev->model, at, &dev->active.enc, s->counts, 0, &pt,
                                          (content & AACMM_CONTENT_JACOBIAN) != 0u ? s->jacobian
                                                                                   : NULL);
        } else {
            no_temps = 1; /* not an encoder fault */
        }
    }
    if (st == AACMM_OK) {
        for (i = 0; i < 3; i++) {
            s->point_100nm[i] = pt.point_100nm[i];
        }
        s->status |= AACMM_SAMPLE_POINT_VALID;
        if (pt.clipped) {
            s->status |= AACMM_SAMPLE_POINT_CLIPPED;
        }
    } else {
        if (!no_temps) {
            dev->counters.encoder_faults++;
            s->status |= AACMM_SAMPLE_ENCODER_FAULT;
        } else if (temps_good) { /* the scaling itself failed (a length beyond the limit) */
            s->status |= AACMM_SAMPLE_TEMP_FAULT;
            dev->counters.temp_faults++;
        }
        for (i = 0; i < 3; i++) {
            s->point_100nm[i] = 0;
        }
        if ((content & AACMM_CONTENT_JACOBIAN) != 0u) {
            for (i = 0; i < AACMM_JAC_SIZE_MAX; i++) {
                s->jacobian[i] = 0.0f;
            }
        }
    }
    if (capture_held(dev) != 0u) {
        s->status |= AACMM_SAMPLE_TRIGGER_DOWN;
    }
    if (dev->param_source == AACMM_PARAM_SOURCE_DEFAULTS) {
        s->status |= AACMM_SAMPLE_PARAMS_DEFAULT;
    }
}

/* ------------------------------------------------------------------------ */
/* info                                                                      */
/* ------------------------------------------------------------------------ */

uint32_t aacmm_device_build_flags(const aacmm_device_t *dev)
{
    uint32_t f = aacmm_device_kin_flags() | AACMM_BUILD_JACOBIAN;
    if (dev == NULL) {
        return f;
    }
    if (dev->serial.present) {
        f |= AACMM_BUILD_SERIAL;
    }
    if (dev->can.present) {
        f |= AACMM_BUILD_CAN;
    }
    if (dev->pf.read_temperatures != NULL) {
        f |= AACMM_BUILD_TEMPERATURES;
    }
    return f;
}

aacmm_status_t aacmm_device_info(const aacmm_device_t *dev, aacmm_msg_info_t *info)
{
    if (dev == NULL || info == NULL) {
        return AACMM_ERR_NULL;
    }
    info->protocol_version = (uint16_t)AACMM_PROTO_VERSION;
    info->fw_major = (uint8_t)AACMM_FW_MAJOR;
    info->fw_minor = (uint8_t)AACMM_FW_MINOR;
    info->fw_patch = (uint16_t)AACMM_FW_PATCH;
    info->build_flags = aacmm_device_build_flags(dev);
    info->param_crc32 = dev->active_crc32;
    info->param_source = dev->param_source;
    info->storage_state = dev->storage_state;
    info->max_body_bytes = (uint16_t)AACMM_PROTO_MAX_BODY;
    info->serial_number = dev->serial_number;
    info->can_node_id = dev->can.node_id;
    info->joints = active_joints(dev);
    info->params = active_params(dev);
    return AACMM_OK;
}

aacmm_status_t aacmm_device_diag(const aacmm_device_t *dev, aacmm_msg_diag_t *diag)
{
    const aacmm_deframer_stats_t *d;
    int i;
    if (dev == NULL || diag == NULL) {
        return AACMM_ERR_NULL;
    }
    d = &dev->serial.deframer.stats;
    diag->storage_kind = dev->storage_ok ? dev->pf.storage_kind : (uint8_t)AACMM_STORAGE_KIND_NONE;
    diag->storage_flags = dev->storage_ok ? (uint8_t)(dev->pf.storage_flags &
                                                      AACMM_STORAGE_FLAGS_KNOWN)
                                          : 0u;
    for (i = 0; i < 2; i++) {
        diag->slot_state[i] = dev->store.slot_state[i];
        diag->slot_generation[i] = dev->store.slot_generation[i];
    }
    diag->storage_errors = dev->counters.storage_errors;
    diag->storage_bad_records = dev->counters.storage_bad_records;
    diag->reset_cause = dev->reset_cause;
    diag->reset_raw = dev->reset_raw;
    diag->fault_pc = dev->fault_pc;
    diag->boot_count = dev->boot_count;
    diag->watchdog_ms = dev->watchdog_ms;
    diag->uptime_us = now_us(dev) - dev->start_us;
    diag->encoder_faults = dev->counters.encoder_faults;
    diag->serial_frames_bad = d->crc_errors + d->cobs_errors + d->runts + d->oversize;
    diag->samples_dropped = dev->counters.samples_dropped;
    diag->samples_late = dev->counters.samples_late;
    diag->joints = active_joints(dev);
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        const aacmm_device_joint_t *j = &dev->joints[i];
        int on = i < (int)diag->joints;
        diag->joint[i].interface = on ? j->interface : 0u;
        diag->joint[i].bits = on ? j->bits : 0u;
        diag->joint[i].last_fault = on ? j->last_fault : 0u;
        diag->joint[i].faults = on ? j->faults : 0u;
        diag->joint[i].warnings = on ? j->warnings : 0u;
    }
    diag->temp_faults = dev->counters.temp_faults;
    return AACMM_OK;
}

/* ------------------------------------------------------------------------ */
/* requests                                                                  */
/* ------------------------------------------------------------------------ */

static void set_error(aacmm_msg_t *rsp, aacmm_status_t st, uint8_t req_type)
{
    rsp->type = (uint8_t)AACMM_MSG_ERROR_RSP;
    rsp->u.error.status = (int16_t)st;
    rsp->u.error.request_type = req_type;
}

/* A sample content the device can deliver: TEMPERATURES needs sensors; both
 * contents must fit one body (not N 7 with P 37). */
static aacmm_status_t check_content(const aacmm_device_t *dev, uint8_t content)
{
    if ((content & AACMM_CONTENT_TEMPERATURES) == 0u) {
        return AACMM_OK;
    }
    if (dev->pf.read_temperatures == NULL) {
        return AACMM_ERR_UNSUPPORTED;
    }
    if (AACMM_PROTO_HEADER_BYTES +
            AACMM_SAMPLE_BYTES((size_t)active_joints(dev), (size_t)active_params(dev), content) >
        AACMM_PROTO_MAX_BODY) {
        return AACMM_ERR_RANGE;
    }
    return AACMM_OK;
}

static void stream_start(aacmm_device_t *dev, aacmm_device_stream_t *s, uint16_t rate_hz,
                         uint8_t content)
{
    s->active = 1u;
    s->starts++;
    s->rate_hz = rate_hz;
    s->content = content;
    s->overrun = 0u;
    s->sent_any = 0u;
    s->seq = 0u;
    s->last_seq = 0u;
    s->start_us = now_us(dev);
    s->index = 0u;
    s->next_us = s->start_us;
}

/* Build the response to the request in body[0..len-1] (from link) in dev->msg_out. */
static void handle_request(aacmm_device_t *dev, unsigned link, const uint8_t *body, size_t len)
{
    aacmm_msg_t *req = &dev->msg_in;
    aacmm_msg_t *rsp = &dev->msg_out;
    aacmm_status_t st = aacmm_msg_decode(body, len, req);
    dev->reply_version = (uint8_t)(st == AACMM_ERR_VERSION && len > 0u &&
                                           body[0] >= (uint8_t)AACMM_PROTO_VERSION_OLDEST &&
                                           body[0] <= (uint8_t)AACMM_PROTO_VERSION_PREVIOUS
                                       ? body[0]
                                       : 0u);
    rsp->seq = req->seq;
    rsp->type = (uint8_t)(req->type | AACMM_MSG_RESPONSE_BIT);
    dev->counters.requests++;
    if (st != AACMM_OK) {
        set_error(rsp, st, req->type);
        return;
    }
    switch (req->type) {
    case AACMM_MSG_PING_REQ:
        rsp->u.ping.token = req->u.ping.token;
        break;
    case AACMM_MSG_INFO_REQ:
        (void)aacmm_device_info(dev, &rsp->u.info);
        break;
    case AACMM_MSG_GET_PARAMS_REQ:
        rsp->u.params = dev->active;
        break;
    case AACMM_MSG_SET_PARAMS_REQ: {
        aacmm_device_model_t model;
        uint32_t crc = 0u;
        st = check_set(dev, &req->u.params, &model, &crc);
        if (st == AACMM_OK) {
            st = check_joints_served(dev, &req->u.params);
        }
        if (st != AACMM_OK) {
            set_error(rsp, st, req->type);
            break;
        }
        /* Set but not saved, unless it is exactly the stored set. */
        activate(dev, &req->u.params, &model, crc,
                 (uint8_t)(dev->have_stored && crc == dev->stored_crc32
                               ? AACMM_PARAM_SOURCE_STORAGE
                               : AACMM_PARAM_SOURCE_HOST));
        rsp->u.param_crc.param_crc32 = crc;
        break;
    }
    case AACMM_MSG_SAVE_PARAMS_REQ:
        if (!dev->storage_ok) {
            set_error(rsp, AACMM_ERR_UNSUPPORTED, req->type);
            break;
        }
        st = aacmm_store_save(&dev->pf, &dev->active, &dev->store, dev->record);
        if (st != AACMM_OK) {
            dev->counters.storage_errors++;
            dev->have_stored = (uint8_t)(dev->store.newest != 0xFFu);
            set_error(rsp, st == AACMM_ERR_IO ? AACMM_ERR_STORAGE : st, req->type);
            break;
        }
        dev->storage_state = (uint8_t)AACMM_STORAGE_OK;
        dev->have_stored = 1u;
        dev->stored_crc32 = dev->active_crc32;
        dev->param_source = (uint8_t)AACMM_PARAM_SOURCE_STORAGE; /* what a restart loads */
        rsp->u.param_crc.param_crc32 = dev->active_crc32;
        break;
    case AACMM_MSG_RESTORE_DEFAULTS_REQ: {
        aacmm_device_model_t model;
        uint32_t crc = 0u;
        st = check_set(dev, &dev->defaults, &model, &crc); /* checked at init: cannot fail */
        if (st == AACMM_OK) {
            st = check_joints_served(dev, &dev->defaults);
        }
        if (st != AACMM_OK) {
            set_error(rsp, st, req->type);
            break;
        }
        activate(dev, &dev->defaults, &model, crc, (uint8_t)AACMM_PARAM_SOURCE_DEFAULTS);
        rsp->u.param_crc.param_crc32 = crc;
        break;
    }
    case AACMM_MSG_MEASURE_REQ:
        st = check_content(dev, req->u.measure.content);
        if (st != AACMM_OK) {
            set_error(rsp, st, req->type);
            break;
        }
        take_sample(dev, req->u.measure.content, &rsp->u.sample);
        rsp->u.sample.seq = dev->measure_seq++;
        break;
    case AACMM_MSG_COMPUTE_REQ: {
        aacmm_msg_compute_rsp_t *c = &rsp->u.compute_rsp;
        uint8_t content = req->u.compute_req.content;
        aacmm_device_point_t pt;
        const aacmm_device_thermal_t *at = NULL;
        int i;
        if (req->u.compute_req.joints != active_joints(dev)) {
            set_error(rsp, AACMM_ERR_RANGE, req->type); /* counts of another arm model */
            break;
        }
        if ((content & AACMM_CONTENT_TEMPERATURES) != 0u && dev->model.thermal != 0u) {
            /* at the request's temperatures (the cache then holds them);
             * without the thermal block they change nothing */
            st = aacmm_device_kin_at_temperature(&dev->model, &dev->at_temp,
                                                 req->u.compute_req.temp);
            if (st != AACMM_OK) {
                set_error(rsp, st, req->type);
                break;
            }
            at = &dev->at_temp;
        }
        st = aacmm_device_kin_compute(&dev->model, at, &dev->active.enc, req->u.compute_req.counts,
                                      1, &pt,
                                      (content & AACMM_CONTENT_JACOBIAN) != 0u ? c->jacobian : NULL);
        if (st != AACMM_OK) {
            set_error(rsp, st, req->type);
            break;
        }
        for (i = 0; i < 3; i++) {
            c->point_mm[i] = pt.point_mm[i];
        }
        c->status = AACMM_SAMPLE_POINT_VALID;
        if (dev->param_source == AACMM_PARAM_SOURCE_DEFAULTS) {
            c->status |= AACMM_SAMPLE_PARAMS_DEFAULT;
        }
        c->content = content;
        c->params = active_params(dev);
        break;
    }
    case AACMM_MSG_STREAM_START_REQ: {
        aacmm_device_stream_t *s = link == AACMM_LINK_SERIAL ? &dev->serial.stream
                                                             : &dev->can.stream;
        uint8_t content = req->u.stream.content;
        uint16_t rate = req->u.stream.rate_hz;
        st = check_content(dev, content);
        if (st != AACMM_OK) {
            set_error(rsp, st, req->type);
            break;
        }
        if (link != AACMM_LINK_SERIAL && content != 0u && rate > AACMM_DEVICE_CAN_JAC_RATE_MAX_HZ) {
            rate = (uint16_t)AACMM_DEVICE_CAN_JAC_RATE_MAX_HZ;
        }
        stream_start(dev, s, rate, content);
        rsp->u.stream.rate_hz = rate;
        rsp->u.stream.content = content;
        break;
    }
    case AACMM_MSG_STREAM_STOP_REQ:
        if (link == AACMM_LINK_SERIAL) {
            dev->serial.stream.active = 0u;
        } else {
            dev->can.stream.active = 0u;
        }
        break;
    case AACMM_MSG_DIAG_REQ:
        (void)aacmm_device_diag(dev, &rsp->u.diag);
        break;
    default: /* a response or an event sent to the device */
        set_error(rsp, AACMM_ERR_UNKNOWN_TYPE, req->type);
        break;
    }
}

/* ------------------------------------------------------------------------ */
/* serial link                                                               */
/* ------------------------------------------------------------------------ */

/* Frame msg into dev->wire; returns the wire length or 0 on error. */
/* The version byte of an answer: a request of the previous version gets
 * its ERR_VERSION answer in that version (ERROR_RSP is laid out alike). */
static void patch_version(const aacmm_device_t *dev, const aacmm_msg_t *msg, uint8_t *body)
{
    if (msg->type == (uint8_t)AACMM_MSG_ERROR_RSP && dev->reply_version != 0u) {
        body[0] = dev->reply_version;
    }
}

static size_t frame_msg(aacmm_device_t *dev, const aacmm_msg_t *msg)
{
    size_t body_len = 0u;
    size_t n = 0u;
    if (aacmm_msg_encode(msg, dev->body, sizeof dev->body, &body_len) != AACMM_OK) {
        return 0u;
    }
    patch_version(dev, msg, dev->body);
    if (aacmm_frame_encode(dev->body, body_len, dev->wire, sizeof dev->wire, &n) != AACMM_OK) {
        return 0u;
    }
    return n;
}

/* Hand the stage (the frame in progress) to the driver. Returns 1 when it
 * is empty afterwards. */
static int serial_stage_drain(aacmm_device_t *dev)
{
    aacmm_device_serial_t *s = &dev->serial;
    if (s->stage_sample && s->stage_pos == 0u && s->stage_len > 0u &&
        (uint32_t)(now_ms32(now_us(dev)) - s->stage_t_ms) > dev->max_sample_age_ms) {
        /* staged but not started, and stale by now */
        s->stage_len = 0u;
        s->stage_sample = 0u;
        dev->counters.samples_dropped++;
        dev->counters.samples_stale++;
        s->stale_overrun = 1u;
    }
    while (s->stage_pos < s->stage_len) {
        size_t chunk = s->stage_len - s->stage_pos;
        size_t done = 0u;
        if (dev->pf.serial_write(dev->pf.ctx, dev->wire + s->stage_pos, chunk, &done) !=
            AACMM_OK) {
            dev->counters.serial_io_errors++;
            return 0;
        }
        if (done > chunk) {
            done = chunk;
        }
        s->stage_pos += done;
        if (done < chunk) {
            return 0; /* driver full */
        }
    }
    s->stage_pos = 0u;
    s->stage_len = 0u;
    return 1;
}

/* Move the next queued body into the stage: samples that waited longer than
 * max_sample_age are dropped on the way (counted; the next sample framed
 * carries OVERRUN). Returns 1 if the stage got a frame. */
static int serial_stage_next(aacmm_device_t *dev)
{
    aacmm_device_serial_t *s = &dev->serial;
    uint32_t now_ms = now_ms32(now_us(dev));
    while (s->txq_len >= TXQ_HDR) {
        size_t n = (size_t)txq_peek(s, 0) | ((size_t)txq_peek(s, 1) << 8);
        uint32_t t = (uint32_t)txq_peek(s, 2) | ((uint32_t)txq_peek(s, 3) << 8) |
                     ((uint32_t)txq_peek(s, 4) << 16) | ((uint32_t)txq_peek(s, 5) << 24);
        uint8_t type = txq_peek(s, TXQ_HDR + 1u);
        size_t wl = 0u;
        txq_take(s, NULL, TXQ_HDR);
        if (type == (uint8_t)AACMM_MSG_SAMPLE_EVT && (uint32_t)(now_ms - t) > dev->max_sample_age_ms) {
            txq_take(s, NULL, n); /* stale: the host would get it too late */
            dev->counters.samples_dropped++;
            dev->counters.samples_stale++;
            s->stale_overrun = 1u;
            continue;
        }
        txq_take(s, dev->body, n);
        if (type == (uint8_t)AACMM_MSG_SAMPLE_EVT && s->stale_overrun) {
            /* status: u32 at sample offset 24 (after seq, timestamp and the
             * point: docs/protocol.md 2.4), OVERRUN in its low byte */
            dev->body[AACMM_PROTO_HEADER_BYTES + 24u] |= (uint8_t)AACMM_SAMPLE_OVERRUN;
            s->stale_overrun = 0u;
        }
        if (aacmm_frame_encode(dev->body, n, dev->wire, sizeof dev->wire, &wl) != AACMM_OK) {
            continue; /* cannot happen: the body was encoded by us */
        }
        s->stage_len = wl;
        s->stage_pos = 0u;
        s->stage_sample = (uint8_t)(type == (uint8_t)AACMM_MSG_SAMPLE_EVT);
        s->stage_t_ms = t;
        return 1;
    }
    return 0;
}

/* Send what the driver takes: the frame in progress, then queued bodies. */
static void serial_flush(aacmm_device_t *dev)
{
    while (serial_stage_drain(dev)) {
        if (!serial_stage_next(dev)) {
            return;
        }
    }
}

/* Frame a response into the empty stage and send it (the caller made sure
 * the stage was empty before taking the request). */
static void serial_send_response(aacmm_device_t *dev, const aacmm_msg_t *msg)
{
    size_t n;
    if (dev->serial.stage_len != 0u) {
        return; /* cannot happen: requests are taken only with an empty stage */
    }
    n = frame_msg(dev, msg);
    if (n == 0u) {
        return; /* cannot happen: responses are encodable */
    }
    dev->serial.stage_len = n;
    dev->serial.stage_pos = 0u;
    dev->serial.stage_sample = 0u;
    if (msg->type == (uint8_t)AACMM_MSG_ERROR_RSP) {
        dev->counters.error_responses++;
    }
    (void)serial_stage_drain(dev);
}

/* Queue a droppable message (sample or event). Returns 1 if queued. */
static int serial_send_droppable(aacmm_device_t *dev, const aacmm_msg_t *msg)
{
    aacmm_device_serial_t *s = &dev->serial;
    const aacmm_sample_t *smp = msg->type == (uint8_t)AACMM_MSG_TRIGGER_EVT
                                    ? &msg->u.trigger.sample
                                    : &msg->u.sample;
    size_t need = AACMM_PROTO_HEADER_BYTES +
                  (msg->type == (uint8_t)AACMM_MSG_TRIGGER_EVT ? AACMM_TRIGGER_EXTRA_BYTES : 0u) +
                  AACMM_SAMPLE_BYTES((size_t)smp->joints, (size_t)smp->params, smp->content);
    size_t n = 0u;
    uint8_t hdr[TXQ_HDR];
    uint32_t t = now_ms32(now_us(dev));
    if (txq_free(s) < TXQ_HDR + need) {
        serial_flush(dev); /* make room if the driver can take bytes now */
        if (txq_free(s) < TXQ_HDR + need) {
            return 0;
        }
    }
    if (aacmm_msg_encode(msg, dev->body, sizeof dev->body, &n) != AACMM_OK || n != need) {
        return 0;
    }
    aacmm_le_put_u16(&hdr[0], (uint16_t)n);
    aacmm_le_put_u32(&hdr[2], t);
    txq_put(s, hdr, TXQ_HDR);
    txq_put(s, dev->body, n);
    return 1;
}

#define SERIAL_CHUNKS_PER_POLL (AACMM_DEVICE_SERIAL_RX_BYTES_PER_POLL / AACMM_DEVICE_SERIAL_RX_CHUNK)

static void serial_receive(aacmm_device_t *dev)
{
    aacmm_device_serial_t *s = &dev->serial;
    unsigned reads = 0u;
    for (;;) {
        const uint8_t *body = NULL;
        size_t body_len = 0u;
        if (!serial_stage_drain(dev)) {
            return; /* the frame in progress is not out yet: the request waits */
        }
        if (s->rx_pos == s->rx_len) {
            size_t got = 0u;
            if (reads == SERIAL_CHUNKS_PER_POLL) {
                return;
            }
            reads++;
            s->rx_pos = 0u;
            s->rx_len = 0u;
            if (dev->pf.serial_read(dev->pf.ctx, s->rx, sizeof s->rx, &got) != AACMM_OK) {
                dev->counters.serial_io_errors++;
                return;
            }
            if (got == 0u) {
                return;
            }
            s->rx_len = got > sizeof s->rx ? sizeof s->rx : got;
        }
        s->rx_pos += aacmm_deframer_feed(&s->deframer, s->rx + s->rx_pos, s->rx_len - s->rx_pos,
                                         &body, &body_len);
        if (body != NULL) {
            handle_request(dev, AACMM_LINK_SERIAL, body, body_len);
            serial_send_response(dev, &dev->msg_out);
        }
    }
}

/* ------------------------------------------------------------------------ */
/* CAN link                                                                  */
/* ------------------------------------------------------------------------ */

static void can_flush(aacmm_device_t *dev)
{
    aacmm_device_can_t *c = &dev->can;
    while (c->q_len > 0u) {
        aacmm_status_t st = dev->pf.can_send(dev->pf.ctx, &c->q[c->q_head]);
        if (st == AACMM_ERR_BUSY) {
            return;
        }
        if (st != AACMM_OK) {
            dev->counters.can_io_errors++; /* the frame is dropped */
        }
        c->q_head = (c->q_head + 1u) % AACMM_DEVICE_CAN_QUEUE;
        c->q_len--;
    }
}

/* Start the next ISO-TP transmission if the endpoint is free, and move its
 * frames into the CAN queue. */
static void can_isotp_service(aacmm_device_t *dev, uint64_t t_us)
{
    aacmm_device_can_t *c = &dev->can;
    uint32_t ms = now_ms32(t_us);
    aacmm_can_frame_t f;
    if (aacmm_isotp_tx_result(&c->tp) != AACMM_ERR_BUSY) {
        if (c->rsp_len > 0u) {
            if (aacmm_isotp_send(&c->tp, c->rsp, c->rsp_len, ms) == AACMM_OK) {
                c->rsp_len = 0u;
            }
        } else if (c->evt_len > 0u) {
            if (aacmm_isotp_send(&c->tp, c->evt, c->evt_len, ms) == AACMM_OK) {
                c->evt_len = 0u;
            }
        }
    }
    while (canq_free(c) > 0u && aacmm_isotp_poll(&c->tp, ms, &f)) {
        canq_put(c, &f);
    }
}

static void can_send_response(aacmm_device_t *dev, const aacmm_msg_t *msg)
{
    aacmm_device_can_t *c = &dev->can;
    size_t n = 0u;
    if (c->rsp_len > 0u) {
        dev->counters.can_rsp_dropped++; /* the previous response is still waiting */
        return;
    }
    if (aacmm_msg_encode(msg, c->rsp, sizeof c->rsp, &n) != AACMM_OK) {
        return;
    }
    patch_version(dev, msg, c->rsp);
    c->rsp_len = n;
    if (msg->type == (uint8_t)AACMM_MSG_ERROR_RSP) {
        dev->counters.error_responses++;
    }
}

static void can_receive(aacmm_device_t *dev)
{
    aacmm_device_can_t *c = &dev->can;
    unsigned k;
    for (k = 0u; k < AACMM_DEVICE_CAN_RX_PER_POLL; k++) {
        aacmm_can_frame_t f;
        const uint8_t *data = NULL;
        size_t len = 0u;
        int got = 0;
        uint64_t t;
        if (dev->pf.can_receive(dev->pf.ctx, &f, &got) != AACMM_OK) {
            dev->counters.can_io_errors++;
            return;
        }
        if (!got) {
            return;
        }
        t = now_us(dev);
        aacmm_isotp_on_frame(&c->tp, &f, now_ms32(t));
        if (aacmm_isotp_receive(&c->tp, &data, &len)) {
            handle_request(dev, AACMM_LINK_CAN, data, len);
            can_send_response(dev, &dev->msg_out);
        }
        /* Flow control for a multi-frame request goes out promptly. */
        can_isotp_service(dev, t);
    }
}

/* ------------------------------------------------------------------------ */
/* streams and events                                                        */
/* ------------------------------------------------------------------------ */

/* Queue the 5 to 7 frames of a sample (all or none, keeping room for
 * ISO-TP). Returns 1 if queued. */
static int can_queue_sample(aacmm_device_t *dev, const aacmm_sample_t *sample)
{
    aacmm_can_frame_t frames[AACMM_CAN_SAMPLE_FRAMES_MAX];
    size_t n = 0u;
    size_t need = AACMM_CAN_SAMPLE_FRAMES((size_t)sample->joints) + CAN_SAMPLE_RESERVE;
    size_t i;
    if (canq_free(&dev->can) < need) {
        can_flush(dev);
    }
    if (canq_free(&dev->can) < need ||
        aacmm_can_sample_encode(sample, dev->can.node_id, frames, &n) != AACMM_OK) {
        return 0;
    }
    for (i = 0; i < n; i++) {
        canq_put(&dev->can, &frames[i]);
    }
    return 1;
}

/* Emit sample number s->seq on link; returns 1 if it went into the queue. */
static int emit_stream_sample(aacmm_device_t *dev, unsigned link, aacmm_device_stream_t *s)
{
    aacmm_msg_t *m = &dev->msg_out;
    int ok;
    m->type = (uint8_t)AACMM_MSG_SAMPLE_EVT;
    m->seq = dev->event_seq;
    take_sample(dev, s->content, &m->u.sample);
    m->u.sample.seq = s->seq;
    if (s->overrun) {
        m->u.sample.status |= AACMM_SAMPLE_OVERRUN;
    }
    if (link == AACMM_LINK_SERIAL) {
        ok = serial_send_droppable(dev, m);
        if (ok) {
            dev->event_seq++;
        }
    } else if (s->content != 0u) {
        /* With the Jacobian or the temperatures (the sample frames carry
         * neither): SAMPLE_EVT over ISO-TP, if the endpoint is free. */
        aacmm_device_can_t *c = &dev->can;
        size_t n = 0u;
        ok = 0;
        if (c->evt_len == 0u && c->rsp_len == 0u &&
            aacmm_isotp_tx_result(&c->tp) != AACMM_ERR_BUSY &&
            aacmm_msg_encode(m, c->evt, sizeof c->evt, &n) == AACMM_OK) {
            c->evt_len = n;
            dev->event_seq++;
            ok = 1;
        }
    } else {
        ok = can_queue_sample(dev, &m->u.sample);
    }
    if (ok) {
        s->overrun = 0u;
        s->sent_any = 1u;
        s->last_seq = s->seq;
        dev->counters.samples_sent++;
    } else {
        s->overrun = 1u;
        dev->counters.samples_dropped++;
    }
    s->seq++;
    return ok;
}

static void stream_service(aacmm_device_t *dev, unsigned link, aacmm_device_stream_t *s)
{
    uint64_t t;
    uint64_t last_due;
    uint64_t due;
    if (!s->active) {
        return;
    }
    t = now_us(dev);
    if (t < s->next_us) {
        return;
    }
    /* Largest k with deadline(k) <= t:  floor(k * 1e6 / rate) <= t - start
     * <=>  k * 1e6 < (t - start + 1) * rate. */
    last_due = (((t - s->start_us) + 1u) * s->rate_hz + (US_PER_S - 1u)) / US_PER_S - 1u;
    due = last_due - s->index + 1u;
    if (due > dev->max_catch_up) {
        uint64_t skip = due - 1u; /* keep only the newest one */
        dev->counters.samples_late += (uint32_t)(skip > 0xFFFFFFFFu ? 0xFFFFFFFFu : skip);
        s->seq += (uint32_t)(skip & 0xFFFFFFFFu);
        s->index += skip;
        s->overrun = 1u;
        due = 1u;
    }
    while (due > 0u) {
        (void)emit_stream_sample(dev, link, s);
        s->index++;
        due--;
    }
    s->next_us = stream_deadline(s, s->index);
}

/* An edge of button `button`: one trigger event per link, its sample read
 * now, numbered with the link's next stream seq (docs/protocol.md 2.7). With
 * no stream running it carries the temperatures when the device reads them:
 * a point taken before the stream starts is no less a measurement. */
static void button_edge(aacmm_device_t *dev, uint8_t button, uint8_t pressed)
{
    aacmm_msg_t *m = &dev->msg_out;
    aacmm_device_stream_t *ss = &dev->serial.stream;
    uint8_t idle = dev->pf.read_temperatures != NULL ? AACMM_CONTENT_TEMPERATURES : 0u;
    uint8_t content = (dev->serial.present && ss->active) ? ss->content : idle;
    dev->counters.button_edges++;
    m->type = (uint8_t)AACMM_MSG_TRIGGER_EVT;
    m->u.trigger.button = button;
    m->u.trigger.pressed = pressed;
    take_sample(dev, content, &m->u.trigger.sample);
    m->u.trigger.sample.status |= AACMM_SAMPLE_TRIGGER_EVENT;
    if (dev->serial.present) {
        m->seq = dev->event_seq;
        m->u.trigger.sample.seq = ss->seq;
        if (serial_send_droppable(dev, m)) {
            dev->event_seq++;
            dev->counters.events_sent++;
        } else {
            dev->counters.events_dropped++;
        }
    }
    if (dev->can.present) {
        /* The sample as sample frames, then the trigger frame naming it. */
        aacmm_device_can_t *c = &dev->can;
        aacmm_can_frame_t f;
        aacmm_sample_t *smp = &m->u.trigger.sample;
        smp->seq = c->stream.seq;
        smp->content = 0u;
        if (canq_free(c) < AACMM_CAN_SAMPLE_FRAMES((size_t)smp->joints) + 1u) {
            can_flush(dev);
        }
        if (canq_free(c) >= AACMM_CAN_SAMPLE_FRAMES((size_t)smp->joints) + 1u &&
            can_queue_sample(dev, smp) &&
            aacmm_can_trigger_encode(smp->seq, button, pressed, c->node_id, &f) == AACMM_OK) {
            canq_put(c, &f);
            dev->counters.events_sent++;
        } else {
            dev->counters.events_dropped++;
        }
    }
}

static uint8_t read_buttons(aacmm_device_t *dev, uint8_t *levels)
{
    uint8_t pressed = 0u;
    if (dev->pf.read_buttons == NULL ||
        dev->pf.read_buttons(dev->pf.ctx, &pressed) != AACMM_OK) {
        return 0u;
    }
    *levels = (uint8_t)(pressed & ((1u << AACMM_BUTTONS) - 1u));
    return 1u;
}

static void button_service(aacmm_device_t *dev)
{
    uint8_t levels = 0u;
    uint8_t b;
    if (!read_buttons(dev, &levels)) {
        return;
    }
    for (b = 0u; b < AACMM_BUTTONS; b++) {
        uint8_t bit = (uint8_t)(1u << b);
        if ((levels & bit) != (dev->buttons & bit)) {
            dev->buttons = (uint8_t)(dev->buttons ^ bit);
            button_edge(dev, b, (levels & bit) != 0u ? 1u : 0u);
        }
    }
}

/* ------------------------------------------------------------------------ */
/* public                                                                    */
/* ------------------------------------------------------------------------ */

aacmm_status_t aacmm_device_init(aacmm_device_t *dev, const aacmm_device_config_t *config,
                                 const aacmm_platform_t *platform)
{
    aacmm_status_t st;
    aacmm_device_model_t model;
    uint32_t crc = 0u;
    int has_serial;
    int has_can;
    if (dev == NULL || config == NULL || platform == NULL || platform->time_us == NULL ||
        (platform->read_encoders == NULL && platform->read_encoder_frames == NULL)) {
        return AACMM_ERR_NULL;
    }
    if (platform->read_encoder_frames != NULL) {
        int j;
        for (j = 0; j < AACMM_JOINTS_MAX; j++) {
            if (j == AACMM_JOINTS && enc_absent(&config->encoders[j])) {
                continue; /* six encoders: 7-joint sets are refused */
            }
            if (aacmm_enc_config_validate(&config->encoders[j]) != AACMM_OK) {
                return AACMM_ERR_RANGE;
            }
        }
    }
    if (config->joints_exact != 0u &&
        (config->joints_exact < AACMM_JOINTS_MIN || config->joints_exact > AACMM_JOINTS_MAX)) {
        return AACMM_ERR_RANGE;
    }
    has_serial = platform->serial_read != NULL && platform->serial_write != NULL;
    has_can = platform->can_send != NULL && platform->can_receive != NULL;
    if (!has_serial && !has_can) {
        return AACMM_ERR_RANGE;
    }
    if (has_serial && config->serial_txq == NULL) {
        return AACMM_ERR_NULL;
    }
    if (has_serial && config->serial_txq_bytes < AACMM_DEVICE_SERIAL_TXQ_MIN) {
        return AACMM_ERR_RANGE;
    }
    if (config->can_node_id > AACMM_CAN_NODE_ID_MAX) {
        return AACMM_ERR_RANGE;
    }

    memset(dev, 0, sizeof *dev);
    dev->pf = *platform;
    dev->serial_number = config->serial_number;
    dev->max_catch_up = config->max_catch_up != 0u ? config->max_catch_up : AACMM_DEVICE_MAX_CATCH_UP;
    dev->max_sample_age_ms = config->max_sample_age_ms != 0u ? config->max_sample_age_ms
                                                             : AACMM_DEVICE_MAX_SAMPLE_AGE_MS;
    dev->store.newest = 0xFFu;
    dev->start_us = platform->time_us(platform->ctx);
    dev->reset_cause = config->reset_cause <= AACMM_RESET_CAUSE_MAX ? config->reset_cause
                                                                    : (uint8_t)AACMM_RESET_UNKNOWN;
    dev->reset_raw = config->reset_raw;
    dev->fault_pc = config->fault_pc;
    dev->boot_count = config->boot_count;
    dev->watchdog_ms = config->watchdog_ms;
    dev->frame_joints = (uint8_t)AACMM_JOINTS_MAX;
    dev->joints_exact = config->joints_exact;
    if (platform->read_encoder_frames != NULL) {
        int j;
        if (enc_absent(&config->encoders[AACMM_JOINTS])) {
            dev->frame_joints = (uint8_t)AACMM_JOINTS;
        }
        for (j = 0; j < AACMM_JOINTS_MAX; j++) {
            dev->encoders[j] = config->encoders[j];
            dev->joints[j].interface = config->encoders[j].interface;
            dev->joints[j].bits = config->encoders[j].bits;
        }
    }
    if (dev->pf.storage_kind > AACMM_STORAGE_KIND_MAX) {
        dev->pf.storage_kind = (uint8_t)AACMM_STORAGE_KIND_NONE;
    }

    /* Defaults. */
    if (config->defaults != NULL) {
        dev->defaults = *config->defaults;
    } else {
        (void)aacmm_param_set_default(&dev->defaults);
    }
    st = check_set(dev, &dev->defaults, &model, &crc);
    if (st != AACMM_OK) {
        return st == AACMM_ERR_NULL ? AACMM_ERR_NULL : AACMM_ERR_RANGE;
    }
    activate(dev, &dev->defaults, &model, crc, (uint8_t)AACMM_PARAM_SOURCE_DEFAULTS);

    /* Stored set. */
    dev->storage_ok = (uint8_t)(platform->storage_read != NULL && platform->storage_write != NULL &&
                                platform->storage_bytes >= AACMM_STORE_BYTES);
    dev->storage_state = (uint8_t)AACMM_STORAGE_EMPTY;
    if (dev->storage_ok) {
        aacmm_param_set_t stored;
        uint8_t state = (uint8_t)AACMM_STORAGE_EMPTY;
        st = aacmm_store_load(&dev->pf, &stored, &state, &dev->store,
                              &dev->counters.storage_bad_records, dev->record);
        if (st == AACMM_ERR_IO) {
            dev->counters.storage_errors++;
        }
        dev->storage_state = state;
        if (st == AACMM_OK) {
            if (check_set(dev, &stored, &model, &crc) == AACMM_OK) {
                activate(dev, &stored, &model, crc, (uint8_t)AACMM_PARAM_SOURCE_STORAGE);
                dev->have_stored = 1u;
                dev->stored_crc32 = crc;
            } else { /* valid record the kinematics backend cannot take */
                dev->storage_state = (uint8_t)AACMM_STORAGE_CORRUPT;
                dev->store.slot_state[dev->store.newest] = (uint8_t)AACMM_SLOT_BAD_CONTENTS;
                dev->store.newest = 0xFFu;
                dev->counters.storage_bad_records++;
            }
        }
    }

    /* Links. */
    if (has_serial) {
        dev->serial.present = 1u;
        dev->serial.txq = config->serial_txq;
        dev->serial.txq_cap = config->serial_txq_bytes;
        aacmm_deframer_init(&dev->serial.deframer);
    }
    if (has_can) {
        aacmm_isotp_config_t tc;
        dev->can.present = 1u;
        dev->can.node_id = config->can_node_id;
        tc.tx_id = AACMM_CAN_ID_ISOTP_RESPONSE + config->can_node_id;
        tc.rx_id = AACMM_CAN_ID_ISOTP_REQUEST + config->can_node_id;
        tc.rx_buf = dev->can.tp_rx;
        tc.rx_cap = sizeof dev->can.tp_rx;
        tc.tx_buf = dev->can.tp_tx;
        tc.tx_cap = sizeof dev->can.tp_tx;
        tc.block_size = 0u;
        tc.st_min = 0u;
        tc.padding = 0xCCu;
        tc.max_wait = (uint8_t)AACMM_ISOTP_DEFAULT_MAX_WAIT;
        tc.timeout_ms = AACMM_ISOTP_DEFAULT_TIMEOUT_MS;
        st = aacmm_isotp_init(&dev->can.tp, &tc);
        if (st != AACMM_OK) {
            return st;
        }
    } else {
        dev->can.node_id = config->can_node_id;
    }

    /* Buttons: the levels at start-up are not edges. */
    (void)read_buttons(dev, &dev->buttons);
    return AACMM_OK;
}

aacmm_status_t aacmm_device_poll(aacmm_device_t *dev)
{
    if (dev == NULL) {
        return AACMM_ERR_NULL;
    }
    if (dev->serial.present) {
        serial_receive(dev); /* responses first: they only wait for the frame in progress */
    }
    if (dev->can.present) {
        can_flush(dev);
        can_receive(dev);
        can_isotp_service(dev, now_us(dev)); /* responses before samples */
    }
    button_service(dev);
    if (dev->serial.present) {
        stream_service(dev, AACMM_LINK_SERIAL, &dev->serial.stream);
        serial_flush(dev);
    }
    if (dev->can.present) {
        stream_service(dev, AACMM_LINK_CAN, &dev->can.stream);
        can_isotp_service(dev, now_us(dev));
        can_flush(dev);
    }
    return AACMM_OK;
}

aacmm_status_t aacmm_device_flush(aacmm_device_t *dev)
{
    if (dev == NULL) {
        return AACMM_ERR_NULL;
    }
    if (dev->serial.present) {
        serial_flush(dev);
    }
    if (dev->can.present) {
        can_isotp_service(dev, now_us(dev));
        can_flush(dev);
    }
    return AACMM_OK;
}

uint64_t aacmm_device_next_deadline_us(const aacmm_device_t *dev)
{
    uint64_t t;
    uint64_t d;
    if (dev == NULL) {
        return 0u;
    }
    t = now_us(dev);
    d = t + AACMM_DEVICE_IDLE_POLL_US;
    if (dev->serial.present) {
        const aacmm_device_serial_t *s = &dev->serial;
        if (s->stream.active && s->stream.next_us < d) {
            d = s->stream.next_us;
        }
        /* Received bytes left over (poll budget) and the stage free to answer: now. */
        if (s->rx_pos < s->rx_len && s->stage_len == 0u) {
            d = t;
        }
    }
    if (dev->can.present) {
        const aacmm_device_can_t *c = &dev->can;
        if (c->stream.active && c->stream.next_us < d) {
            d = c->stream.next_us;
        }
        /* ISO-TP timers run in ms: look again within 1 ms while busy. */
        if ((c->tp.tx_state != 0u || c->tp.rx_state == 1u || c->tp.fc_pending != 0u ||
             c->rsp_len > 0u || c->evt_len > 0u) &&
            t + 1000u < d) {
            d = t + 1000u;
        }
    }
    return d;
}

size_t aacmm_device_serial_pending(const aacmm_device_t *dev)
{
    return dev == NULL ? 0u : dev->serial.txq_len + (dev->serial.stage_len - dev->serial.stage_pos);
}

int aacmm_device_serial_wants_input(const aacmm_device_t *dev)
{
    return dev != NULL && dev->serial.present && dev->serial.stage_len == 0u;
}

size_t aacmm_device_can_pending(const aacmm_device_t *dev)
{
    return dev == NULL ? 0u : dev->can.q_len;
}

aacmm_status_t aacmm_device_stream_info(const aacmm_device_t *dev, unsigned link,
                                        aacmm_device_stream_info_t *info)
{
    const aacmm_device_stream_t *s;
    if (dev == NULL || info == NULL) {
        return AACMM_ERR_NULL;
    }
    if (link == AACMM_LINK_SERIAL) {
        s = &dev->serial.stream;
    } else if (link == AACMM_LINK_CAN) {
        s = &dev->can.stream;
    } else {
        return AACMM_ERR_RANGE;
    }
    info->active = s->active;
    info->content = s->content;
    info->rate_hz = s->rate_hz;
    info->starts = s->starts;
    info->next_seq = s->seq;
    return AACMM_OK;
}

const aacmm_device_counters_t *aacmm_device_counters(const aacmm_device_t *dev)
{
    return dev == NULL ? NULL : &dev->counters;
}

const aacmm_deframer_stats_t *aacmm_device_serial_stats(const aacmm_device_t *dev)
{
    return dev == NULL ? NULL : &dev->serial.deframer.stats;
}

const aacmm_isotp_stats_t *aacmm_device_isotp_stats(const aacmm_device_t *dev)
{
    return dev == NULL ? NULL : &dev->can.tp.stats;
}
