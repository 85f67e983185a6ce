#define _POSIX_C_SOURCE 200809L
#include "vectors.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int hexval(char c)
{
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

static size_t parse_hex(const char *s, uint8_t *out, size_t cap)
{
    size_t n = 0;
    if (strcmp(s, "-") == 0) {
        return 0;
    }
    while (s[0] != '\0' && s[1] != '\0') {
        int hi = hexval(s[0]);
        int lo = hexval(s[1]);
        if (hi < 0 || lo < 0 || n >= cap) {
            fprintf(stderr, "vectors: bad hex near '%.10s'\n", s);
            exit(2);
        }
        out[n++] = (uint8_t)(hi * 16 + lo);
        s += 2;
    }
    if (s[0] != '\0') {
        fprintf(stderr, "vectors: odd hex length\n");
        exit(2);
    }
    return n;
}

size_t vec_load(const char *path, vec_record_t *records, size_t max)
{
    static char line[16384];
    size_t count = 0;
    FILE *f = fopen(path, "r");
    if (f == NULL) {
        fprintf(stderr, "vectors: cannot open %s\n", path);
        exit(2);
    }
    while (fgets(line, sizeof line, f) != NULL) {
        char *tok[6];
        size_t nt = 0;
        char *save = NULL;
        char *t;
        vec_record_t *r;
        if (line[0] == '#' || line[0] == '\n') {
            continue;
        }
        for (t = strtok_r(line, " \t\r\n", &save); t != NULL && nt < 6;
             t = strtok_r(NULL, " \t\r\n", &save)) {
            tok[nt++] = t;
        }
        if (nt < 4 || count >= max) {
            fprintf(stderr, "vectors: bad record or too many records\n");
            exit(2);
        }
        r = &records[count++];
        memset(r, 0, sizeof *r);
        snprintf(r->kind, sizeof r->kind, "%s", tok[0]);
        snprintf(r->name, sizeof r->name, "%s", tok[1]);
        if (strcmp(r->kind, "can") == 0) {
            r->id = (uint32_t)strtoul(tok[2], NULL, 16);
            r->b_len = parse_hex(tok[3], r->b, sizeof r->b);
        } else if (strcmp(r->kind, "isotp") == 0) {
            char *fsave = NULL;
            char *ft;
            r->id = (uint32_t)strtoul(tok[2], NULL, 16);
            r->a_len = parse_hex(tok[3], r->a, sizeof r->a);
            for (ft = strtok_r(tok[4], ",", &fsave); ft != NULL; ft = strtok_r(NULL, ",", &fsave)) {
                if (r->n_frames >= VEC_MAX_FRAMES) {
                    fprintf(stderr, "vectors: too many frames\n");
                    exit(2);
                }
                r->frame_len[r->n_frames] = parse_hex(ft, r->frames[r->n_frames], 8);
                r->n_frames++;
            }
        } else if (strcmp(r->kind, "badbody") == 0 || strcmp(r->kind, "badframe") == 0) {
            r->a_len = parse_hex(tok[2], r->a, sizeof r->a);
            snprintf(r->word, sizeof r->word, "%s", tok[3]);
        } else {
            r->a_len = parse_hex(tok[2], r->a, sizeof r->a);
            r->b_len = parse_hex(tok[3], r->b, sizeof r->b);
        }
    }
    fclose(f);
    return count;
}

void vec_params(aacmm_param_set_t *p)
{
    static const double theta[6] = {0.0, 0.001, -0.002, 0.5, -0.25, 0.3333333333333333};
    static const double alpha[6] = {1.5707963267948966, -1.5707963267948966, 1.5707963267948966,
                                    -1.5707963267948966, 1.5707963267948966, -1.5707963267948966};
    static const double d[6] = {300.0, 65.5, 792.7, 65.5, 883.2, 0.0};
    static const double a[6] = {0.0, -0.125, 0.0, 0.03125, 0.0, -0.0};
    static const uint64_t cpr[6] = {4294967296ull, 16777216u, 131072u, 2u, 4294967295u, 1000000u};
    static const uint32_t zero[6] = {0u, 16777215u, 65536u, 1u, 4294967294u, 999999u};
    static const int8_t dir[6] = {1, -1, 1, -1, 1, -1};
    memset(p, 0, sizeof *p);
    memcpy(p->kin.theta_offset_rad, theta, sizeof theta);
    memcpy(p->kin.alpha_rad, alpha, sizeof alpha);
    memcpy(p->kin.d_mm, d, sizeof d);
    memcpy(p->kin.a_mm, a, sizeof a);
    p->kin.l_mm = 183.5;
    memcpy(p->enc.counts_per_rev, cpr, sizeof cpr);
    memcpy(p->enc.zero_offset_counts, zero, sizeof zero);
    memcpy(p->enc.direction, dir, sizeof dir);
}

void vec_sample_a(aacmm_sample_t *s)
{
    static const uint32_t counts[6] = {0u, 1u, 0x7FFFFFFFu, 0x80000000u, 0xFFFFFFFFu, 0x00FF00FFu};
    memset(s, 0, sizeof *s);
    s->seq = 0xFFFFFFFEu;
    s->timestamp_us = 0x0123456789ABCDEFull;
    memcpy(s->counts, counts, sizeof counts);
    s->point_100nm[0] = 12345678;
    s->point_100nm[1] = -22000000;
    s->point_100nm[2] = -1;
    s->status = 0x80000005u;
    s->content = 0u;
}

static void sample_j(aacmm_sample_t *s)
{
    int i;
    memset(s, 0, sizeof *s);
    s->seq = 42u;
    s->timestamp_us = 1000000u;
    for (i = 0; i < 6; i++) {
        s->counts[i] = (uint32_t)(100 * (i + 1));
    }
    s->point_100nm[0] = 0;
    s->point_100nm[1] = 1;
    s->point_100nm[2] = INT32_MIN;
    s->status = 1u;
    s->content = AACMM_CONTENT_JACOBIAN;
    for (i = 0; i < 74; i++) {
        s->jacobian[i] = (float)(i - 37) * 0.25f;
    }
    s->jacobian[74] = 3.0f / 1048576.0f;
}

int vec_expected_msg(const char *name, aacmm_msg_t *m)
{
    aacmm_param_set_t params;
    uint32_t crc = 0;
    int i;
    vec_params(&params);
    (void)aacmm_param_set_crc32(&params, &crc);
    memset(m, 0, sizeof *m);
#define IS(n) (strcmp(name, n) == 0)
    if (IS("ping_req")) {
        m->type = AACMM_MSG_PING_REQ; m->seq = 0; m->u.ping.token = 0xDEADBEEFu;
    } else if (IS("ping_rsp")) {
        m->type = AACMM_MSG_PING_RSP; m->seq = 0xFF; m->u.ping.token = 0xDEADBEEFu;
    } else if (IS("info_req")) {
        m->type = AACMM_MSG_INFO_REQ; m->seq = 1;
    } else if (IS("info_rsp")) {
        m->type = AACMM_MSG_INFO_RSP; m->seq = 1;
        m->u.info.protocol_version = 1; m->u.info.fw_major = 0; m->u.info.fw_minor = 3;
        m->u.info.fw_patch = 17; m->u.info.build_flags = 0x1Eu; m->u.info.param_crc32 = crc;
        m->u.info.param_source = 1; m->u.info.storage_state = 0; m->u.info.max_body_bytes = 512;
        m->u.info.serial_number = 0xA5C3E001u; m->u.info.can_node_id = 5;
    } else if (IS("get_params_req")) {
        m->type = AACMM_MSG_GET_PARAMS_REQ; m->seq = 2;
    } else if (IS("get_params_rsp")) {
        m->type = AACMM_MSG_GET_PARAMS_RSP; m->seq = 2; m->u.params = params;
    } else if (IS("set_params_req")) {
        m->type = AACMM_MSG_SET_PARAMS_REQ; m->seq = 3; m->u.params = params;
    } else if (IS("set_params_rsp")) {
        m->type = AACMM_MSG_SET_PARAMS_RSP; m->seq = 3; m->u.param_crc.param_crc32 = crc;
    } else if (IS("save_params_req")) {
        m->type = AACMM_MSG_SAVE_PARAMS_REQ; m->seq = 4;
    } else if (IS("save_params_rsp")) {
        m->type = AACMM_MSG_SAVE_PARAMS_RSP; m->seq = 4; m->u.param_crc.param_crc32 = crc;
    } else if (IS("restore_defaults_req")) {
        m->type = AACMM_MSG_RESTORE_DEFAULTS_REQ; m->seq = 5;
    } else if (IS("restore_defaults_rsp")) {
        m->type = AACMM_MSG_RESTORE_DEFAULTS_RSP; m->seq = 5;
        m->u.param_crc.param_crc32 = 0x12345678u;
    } else if (IS("measure_req")) {
        m->type = AACMM_MSG_MEASURE_REQ; m->seq = 6; m->u.measure.content = AACMM_CONTENT_JACOBIAN;
    } else if (IS("measure_rsp")) {
        m->type = AACMM_MSG_MEASURE_RSP; m->seq = 6; sample_j(&m->u.sample);
    } else if (IS("compute_req")) {
        m->type = AACMM_MSG_COMPUTE_REQ; m->seq = 7;
        m->u.compute_req.content = AACMM_CONTENT_JACOBIAN;
        for (i = 0; i < 6; i++) {
            m->u.compute_req.counts[i] = (uint32_t)(i + 1) * 0x01010101u;
        }
    } else if (IS("compute_rsp")) {
        m->type = AACMM_MSG_COMPUTE_RSP; m->seq = 7;
        m->u.compute_rsp.status = 1;
        m->u.compute_rsp.point_mm[0] = 1234.5678901234567;
        m->u.compute_rsp.point_mm[1] = -0.0001;
        m->u.compute_rsp.point_mm[2] = 2200.0;
        m->u.compute_rsp.content = AACMM_CONTENT_JACOBIAN;
        for (i = 0; i < 75; i++) {
            m->u.compute_rsp.jacobian[i] = (float)i * 0.5f;
        }
    } else if (IS("stream_start_req")) {
        m->type = AACMM_MSG_STREAM_START_REQ; m->seq = 8;
        m->u.stream.rate_hz = 1000; m->u.stream.content = 0;
    } else if (IS("stream_start_rsp")) {
        m->type = AACMM_MSG_STREAM_START_RSP; m->seq = 8;
        m->u.stream.rate_hz = 250; m->u.stream.content = AACMM_CONTENT_JACOBIAN;
    } else if (IS("stream_stop_req")) {
        m->type = AACMM_MSG_STREAM_STOP_REQ; m->seq = 9;
    } else if (IS("stream_stop_rsp")) {
        m->type = AACMM_MSG_STREAM_STOP_RSP; m->seq = 9;
    } else if (IS("sample_evt")) {
        m->type = AACMM_MSG_SAMPLE_EVT; m->seq = 10; vec_sample_a(&m->u.sample);
    } else if (IS("trigger_evt")) {
        m->type = AACMM_MSG_TRIGGER_EVT; m->seq = 11;
        m->u.trigger.button = 0; m->u.trigger.pressed = 1; vec_sample_a(&m->u.trigger.sample);
    } else if (IS("diag_req")) {
        m->type = AACMM_MSG_DIAG_REQ; m->seq = 12;
    } else if (IS("diag_rsp")) {
        static const aacmm_diag_joint_t joints[6] = {
            {1, 32, 0, 0u, 0u},         {1, 26, 1, 12u, 3u}, {2, 20, 6, 1u, 0u},
            {3, 13, 3, 0xFFFFFFFFu, 0u}, {0, 0, 7, 2u, 0u},  {1, 1, 8, 1u, 0xFFFFFFFFu},
        };
        aacmm_msg_diag_t *d = &m->u.diag;
        m->type = AACMM_MSG_DIAG_RSP; m->seq = 12;
        d->storage_kind = AACMM_STORAGE_KIND_FLASH; d->storage_flags = AACMM_STORAGE_PERSISTENT;
        d->slot_state[0] = AACMM_SLOT_NEWEST; d->slot_state[1] = AACMM_SLOT_BAD_CRC;
        d->slot_generation[0] = 0x01020304u; d->slot_generation[1] = 0xFFFFFFFFu;
        d->storage_errors = 2u; d->storage_bad_records = 1u;
        d->reset_cause = AACMM_RESET_FAULT; d->reset_raw = 4u; d->fault_pc = 0x12A6u;
        d->boot_count = 3u; d->watchdog_ms = 1000u; d->uptime_us = 0x123456789ull;
        d->encoder_faults = 17u; d->serial_frames_bad = 0x80000000u;
        d->samples_dropped = 5u; d->samples_late = 6u;
        memcpy(d->joints, joints, sizeof joints);
    } else if (IS("error_rsp")) {
        m->type = AACMM_MSG_ERROR_RSP; m->seq = 3;
        m->u.error.status = (int16_t)AACMM_ERR_RANGE; m->u.error.request_type = 0x04;
    } else {
        return 0;
    }
#undef IS
    return 1;
}

static int sample_equal(const aacmm_sample_t *a, const aacmm_sample_t *b)
{
    if (a->seq != b->seq || a->timestamp_us != b->timestamp_us || a->status != b->status ||
        a->content != b->content || memcmp(a->counts, b->counts, sizeof a->counts) != 0 ||
        memcmp(a->point_100nm, b->point_100nm, sizeof a->point_100nm) != 0) {
        return 0;
    }
    if ((a->content & AACMM_CONTENT_JACOBIAN) != 0u &&
        memcmp(a->jacobian, b->jacobian, sizeof a->jacobian) != 0) {
        return 0;
    }
    return 1;
}

int vec_msg_equal(const aacmm_msg_t *x, const aacmm_msg_t *y)
{
    if (x->type != y->type || x->seq != y->seq) {
        return 0;
    }
    switch (x->type) {
    case AACMM_MSG_PING_REQ:
    case AACMM_MSG_PING_RSP:
        return x->u.ping.token == y->u.ping.token;
    case AACMM_MSG_INFO_RSP: {
        const aacmm_msg_info_t *a = &x->u.info;
        const aacmm_msg_info_t *b = &y->u.info;
        return a->protocol_version == b->protocol_version && a->fw_major == b->fw_major &&
               a->fw_minor == b->fw_minor && a->fw_patch == b->fw_patch &&
               a->build_flags == b->build_flags && a->param_crc32 == b->param_crc32 &&
               a->param_source == b->param_source && a->storage_state == b->storage_state &&
               a->max_body_bytes == b->max_body_bytes && a->serial_number == b->serial_number &&
               a->can_node_id == b->can_node_id;
    }
    case AACMM_MSG_SET_PARAMS_REQ:
    case AACMM_MSG_GET_PARAMS_RSP: {
        const aacmm_param_set_t *a = &x->u.params;
        const aacmm_param_set_t *b = &y->u.params;
        return memcmp(&a->kin, &b->kin, sizeof a->kin) == 0 &&
               memcmp(a->enc.counts_per_rev, b->enc.counts_per_rev, sizeof a->enc.counts_per_rev) == 0 &&
               memcmp(a->enc.zero_offset_counts, b->enc.zero_offset_counts,
                      sizeof a->enc.zero_offset_counts) == 0 &&
               memcmp(a->enc.direction, b->enc.direction, sizeof a->enc.direction) == 0;
    }
    case AACMM_MSG_SET_PARAMS_RSP:
    case AACMM_MSG_SAVE_PARAMS_RSP:
    case AACMM_MSG_RESTORE_DEFAULTS_RSP:
        return x->u.param_crc.param_crc32 == y->u.param_crc.param_crc32;
    case AACMM_MSG_MEASURE_REQ:
        return x->u.measure.content == y->u.measure.content;
    case AACMM_MSG_COMPUTE_REQ:
        return x->u.compute_req.content == y->u.compute_req.content &&
               memcmp(x->u.compute_req.counts, y->u.compute_req.counts,
                      sizeof x->u.compute_req.counts) == 0;
    case AACMM_MSG_COMPUTE_RSP: {
        const aacmm_msg_compute_rsp_t *a = &x->u.compute_rsp;
        const aacmm_msg_compute_rsp_t *b = &y->u.compute_rsp;
        if (a->status != b->status || a->content != b->content ||
            memcmp(a->point_mm, b->point_mm, sizeof a->point_mm) != 0) {
            return 0;
        }
        return (a->content & AACMM_CONTENT_JACOBIAN) == 0u ||
               memcmp(a->jacobian, b->jacobian, sizeof a->jacobian) == 0;
    }
    case AACMM_MSG_STREAM_START_REQ:
    case AACMM_MSG_STREAM_START_RSP:
        return x->u.stream.rate_hz == y->u.stream.rate_hz &&
               x->u.stream.content == y->u.stream.content;
    case AACMM_MSG_MEASURE_RSP:
    case AACMM_MSG_SAMPLE_EVT:
        return sample_equal(&x->u.sample, &y->u.sample);
    case AACMM_MSG_TRIGGER_EVT:
        return x->u.trigger.button == y->u.trigger.button &&
               x->u.trigger.pressed == y->u.trigger.pressed &&
               sample_equal(&x->u.trigger.sample, &y->u.trigger.sample);
    case AACMM_MSG_DIAG_RSP: {
        const aacmm_msg_diag_t *a = &x->u.diag;
        const aacmm_msg_diag_t *b = &y->u.diag;
        int k;
        if (a->storage_kind != b->storage_kind || a->storage_flags != b->storage_flags ||
            memcmp(a->slot_state, b->slot_state, sizeof a->slot_state) != 0 ||
            memcmp(a->slot_generation, b->slot_generation, sizeof a->slot_generation) != 0 ||
            a->storage_errors != b->storage_errors ||
            a->storage_bad_records != b->storage_bad_records || a->reset_cause != b->reset_cause ||
            a->reset_raw != b->reset_raw || a->fault_pc != b->fault_pc ||
            a->boot_count != b->boot_count || a->watchdog_ms != b->watchdog_ms ||
            a->uptime_us != b->uptime_us || a->encoder_faults != b->encoder_faults ||
            a->serial_frames_bad != b->serial_frames_bad ||
            a->samples_dropped != b->samples_dropped || a->samples_late != b->samples_late) {
            return 0;
        }
        for (k = 0; k < 6; k++) {
            const aacmm_diag_joint_t *p = &a->joints[k];
            const aacmm_diag_joint_t *q = &b->joints[k];
            if (p->interface != q->interface || p->bits != q->bits ||
                p->last_fault != q->last_fault || p->faults != q->faults ||
                p->warnings != q->warnings) {
                return 0;
            }
        }
        return 1;
    }
    case AACMM_MSG_ERROR_RSP:
        return x->u.error.status == y->u.error.status &&
               x->u.error.request_type == y->u.error.request_type;
    default:
        return 1;
    }
}

int vec_status_from_name(const char *name, aacmm_status_t *st)
{
    static const struct {
        const char *name;
        aacmm_status_t st;
    } table[] = {
        {"OK", AACMM_OK},
        {"ERR_NULL", AACMM_ERR_NULL},
        {"ERR_RANGE", AACMM_ERR_RANGE},
        {"ERR_NOT_FINITE", AACMM_ERR_NOT_FINITE},
        {"ERR_BUFFER", AACMM_ERR_BUFFER},
        {"ERR_CRC", AACMM_ERR_CRC},
        {"ERR_FRAME", AACMM_ERR_FRAME},
        {"ERR_LENGTH", AACMM_ERR_LENGTH},
        {"ERR_UNKNOWN_TYPE", AACMM_ERR_UNKNOWN_TYPE},
        {"ERR_TIMEOUT", AACMM_ERR_TIMEOUT},
        {"ERR_VERSION", AACMM_ERR_VERSION},
    };
    size_t i;
    for (i = 0; i < sizeof table / sizeof table[0]; i++) {
        if (strcmp(table[i].name, name) == 0) {
            *st = table[i].st;
            return 1;
        }
    }
    return 0;
}
