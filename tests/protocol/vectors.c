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
    (void)aacmm_shape_paper(&p->arm.shape);
    memcpy(p->arm.theta_offset_rad, theta, sizeof theta);
    memcpy(p->arm.alpha_rad, alpha, sizeof alpha);
    memcpy(p->arm.d_mm, d, sizeof d);
    memcpy(p->arm.a_mm, a, sizeof a);
    p->arm.tip_mm[2] = 183.5;
    p->enc.joints = 6u;
    memcpy(p->enc.counts_per_rev, cpr, sizeof cpr);
    memcpy(p->enc.zero_offset_counts, zero, sizeof zero);
    memcpy(p->enc.direction, dir, sizeof dir);
}

/* The 7-joint arm model: modified DH on joints 5..7, betas on 3 and 7, a tip
 * vector (P 33); the same values as PARAMS7 of gen_protocol_vectors.py. */
static void vec_params7(aacmm_param_set_t *p)
{
    static const double theta[7] = {0.0, 0.01, -0.02, 0.0, 0.125, -0.5, 1.0};
    static const double alpha[7] = {1.5707963267948966, 0.002, 1.5707963267948966,
                                    -1.5707963267948966, 0.0, 3.0, -0.25};
    static const double d[7] = {250.0, 0.0, 5.0, 550.0, 2.0, 120.0, 60.0};
    static const double a[7] = {0.0, 600.0, 40.0, 0.0, 30.0, 0.0, 3.0};
    static const uint64_t cpr[7] = {4294967296ull, 16777216u, 3600000u, 2u,
                                    4294967295u,   262144u,   1048576u};
    static const uint32_t zero[7] = {0u, 12345u, 3599999u, 1u, 5u, 99u, 524288u};
    static const int8_t dir[7] = {1, -1, 1, 1, -1, 1, -1};
    int i;
    memset(p, 0, sizeof *p);
    p->arm.shape.joints = 7u;
    p->arm.shape.tip = (uint8_t)AACMM_TIP_XYZ;
    for (i = 4; i < 7; i++) {
        p->arm.shape.convention[i] = (uint8_t)AACMM_DH_MODIFIED;
    }
    p->arm.shape.beta[2] = 1u;
    p->arm.shape.beta[6] = 1u;
    memcpy(p->arm.theta_offset_rad, theta, sizeof theta);
    memcpy(p->arm.alpha_rad, alpha, sizeof alpha);
    memcpy(p->arm.d_mm, d, sizeof d);
    memcpy(p->arm.a_mm, a, sizeof a);
    p->arm.beta_rad[2] = 0.0015;
    p->arm.beta_rad[6] = -0.001;
    p->arm.tip_mm[0] = 1.5;
    p->arm.tip_mm[1] = -2.0;
    p->arm.tip_mm[2] = 110.0;
    p->enc.joints = 7u;
    memcpy(p->enc.counts_per_rev, cpr, sizeof cpr);
    memcpy(p->enc.zero_offset_counts, zero, sizeof zero);
    memcpy(p->enc.direction, dir, sizeof dir);
}

/* A 5-joint set with an error model (K 2, the thermal block): PARAMS5E. */
static void vec_params5e(aacmm_param_set_t *p)
{
    static const double theta[5] = {0.0, 0.001, 0.0, -0.001, 0.0};
    static const double alpha[5] = {0.0, 1.5707963267948966, 0.001, -0.0005, 1.5707963267948966};
    static const double d[5] = {210.0, 0.0, 0.5, 1.0, 80.0};
    static const double a[5] = {0.0, 24.0, 260.0, 260.0, 12.0};
    static const uint8_t kk[5] = {2u, 1u, 2u, 0u, 3u};
    static const int16_t hc[5][3] = {{1, -2, 0}, {3, 0, 0}, {32767, -32768, 0}, {0, 0, 0},
                                     {5, 6, -13}};
    static const int16_t hs[5][3] = {{-7, 8, 0}, {9, 0, 0}, {-32768, 32767, 0}, {0, 0, 0},
                                     {11, -12, 14}};
    static const int16_t cte[5] = {2300, 1200, -1, 0, 32767};
    int i;
    memset(p, 0, sizeof *p);
    p->arm.shape.joints = 5u;
    p->arm.shape.tip = (uint8_t)AACMM_TIP_Z;
    for (i = 0; i < 5; i++) {
        p->arm.shape.convention[i] = (uint8_t)AACMM_DH_MODIFIED;
        p->enc.counts_per_rev[i] = 4294967296ull;
        p->enc.zero_offset_counts[i] = (uint32_t)i;
        p->enc.direction[i] = (int8_t)(i == 2 || i == 3 ? -1 : 1);
        p->err.harmonics[i] = kk[i];
        p->err.harm_cos[i][0] = hc[i][0];
        p->err.harm_cos[i][1] = hc[i][1];
        p->err.harm_cos[i][2] = hc[i][2];
        p->err.harm_sin[i][0] = hs[i][0];
        p->err.harm_sin[i][1] = hs[i][1];
        p->err.harm_sin[i][2] = hs[i][2];
        p->err.cte[i] = cte[i];
    }
    p->arm.shape.beta[2] = 1u;
    p->arm.shape.beta[3] = 1u;
    memcpy(p->arm.theta_offset_rad, theta, sizeof theta);
    memcpy(p->arm.alpha_rad, alpha, sizeof alpha);
    memcpy(p->arm.d_mm, d, sizeof d);
    memcpy(p->arm.a_mm, a, sizeof a);
    p->arm.beta_rad[2] = 0.002;
    p->arm.beta_rad[3] = -0.001;
    p->arm.tip_mm[2] = 95.0;
    p->enc.joints = 5u;
    p->err.thermal = 1u;
    p->err.ref_temp = 2000;
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
    s->joints = 6u;
    s->params = 25u;
}

/* Version 4: SAMPLE_T of the generator (six link temperatures, one
 * AACMM_TEMP_NONE, one out of range; TEMP_FAULT set, point valid). */
static void sample_t(aacmm_sample_t *s)
{
    static const int16_t temp[6] = {2000, 2150, -4000, 8500, AACMM_TEMP_NONE, 32767};
    int i;
    memset(s, 0, sizeof *s);
    s->seq = 0x00010000u;
    s->timestamp_us = 86400000000ull;
    for (i = 0; i < 6; i++) {
        s->counts[i] = (uint32_t)(1000 * (i + 1));
    }
    s->point_100nm[0] = 3000000;
    s->point_100nm[1] = -1500000;
    s->point_100nm[2] = 4500000;
    s->status = AACMM_SAMPLE_POINT_VALID | AACMM_SAMPLE_TEMP_FAULT;
    s->content = AACMM_CONTENT_TEMPERATURES;
    s->joints = 6u;
    s->params = 25u;
    memcpy(s->temp, temp, sizeof temp);
}

/* SAMPLE_7TJ: the largest sample (N 7, P 36, temperatures and Jacobian). */
static void sample_7tj(aacmm_sample_t *s)
{
    static const uint32_t counts[7] = {0xFFFFFFFFu, 1u, 2u, 3u, 4u, 5u, 6u};
    static const int16_t temp[7] = {-3999, -1, 0, 1, 2500, 8499, -32767};
    int i;
    memset(s, 0, sizeof *s);
    s->seq = 0xFFFFFFFFu;
    s->timestamp_us = 123456789u;
    memcpy(s->counts, counts, sizeof counts);
    s->point_100nm[0] = INT32_MIN;
    s->point_100nm[1] = 0;
    s->point_100nm[2] = INT32_MAX;
    s->status = AACMM_SAMPLE_POINT_VALID;
    s->content = AACMM_CONTENT_TEMPERATURES | AACMM_CONTENT_JACOBIAN;
    s->joints = 7u;
    s->params = 36u;
    memcpy(s->temp, temp, sizeof temp);
    for (i = 0; i < 108; i++) {
        s->jacobian[i] = (float)(i % 29 - 14) * 0.0625f;
    }
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
    s->joints = 6u;
    s->params = 25u;
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
        m->u.info.protocol_version = 4; m->u.info.fw_major = 0; m->u.info.fw_minor = 3;
        m->u.info.fw_patch = 17; m->u.info.build_flags = 0x1Eu; m->u.info.param_crc32 = crc;
        m->u.info.param_source = 1; m->u.info.storage_state = 0; m->u.info.max_body_bytes = 512;
        m->u.info.serial_number = 0xA5C3E001u; m->u.info.can_node_id = 5;
        m->u.info.joints = 6; m->u.info.params = 25;
    } else if (IS("info_rsp7")) {
        aacmm_param_set_t p7;
        uint32_t crc7 = 0;
        vec_params7(&p7);
        (void)aacmm_param_set_crc32(&p7, &crc7);
        m->type = AACMM_MSG_INFO_RSP; m->seq = 13;
        m->u.info.protocol_version = 4; m->u.info.fw_major = 0; m->u.info.fw_minor = 1;
        m->u.info.fw_patch = 0; m->u.info.build_flags = 0x2Cu; m->u.info.param_crc32 = crc7;
        m->u.info.param_source = 2; m->u.info.storage_state = 1; m->u.info.max_body_bytes = 512;
        m->u.info.serial_number = 77u; m->u.info.can_node_id = 15;
        m->u.info.joints = 7; m->u.info.params = 33;
    } else if (IS("get_params_rsp7")) {
        m->type = AACMM_MSG_GET_PARAMS_RSP; m->seq = 14; vec_params7(&m->u.params);
    } else if (IS("set_params_req5e")) {
        m->type = AACMM_MSG_SET_PARAMS_REQ; m->seq = 15; vec_params5e(&m->u.params);
    } else if (IS("sample_evt7")) {
        static const uint32_t c7[7] = {7u, 6u, 5u, 4u, 3u, 2u, 0xFFFFFFFFu};
        aacmm_sample_t *s = &m->u.sample;
        m->type = AACMM_MSG_SAMPLE_EVT; m->seq = 16;
        s->seq = 7u; s->timestamp_us = 0xFFFFFFFFFFFFull;
        memcpy(s->counts, c7, sizeof c7);
        s->point_100nm[0] = -5; s->point_100nm[1] = INT32_MAX; s->point_100nm[2] = 0;
        s->status = 0x4001u; s->content = AACMM_CONTENT_JACOBIAN; s->joints = 7; s->params = 33;
        for (i = 0; i < 99; i++) {
            s->jacobian[i] = (float)(i % 17 - 8) * 0.125f;
        }
    } else if (IS("compute_req5")) {
        m->type = AACMM_MSG_COMPUTE_REQ; m->seq = 17;
        m->u.compute_req.content = AACMM_CONTENT_JACOBIAN; m->u.compute_req.joints = 5;
        m->u.compute_req.counts[0] = 1u; m->u.compute_req.counts[1] = 0xFFFFFFFFu;
        m->u.compute_req.counts[2] = 3u; m->u.compute_req.counts[3] = 4u;
        m->u.compute_req.counts[4] = 5u;
    } else if (IS("compute_rsp5")) {
        m->type = AACMM_MSG_COMPUTE_RSP; m->seq = 17;
        m->u.compute_rsp.status = 1;
        m->u.compute_rsp.point_mm[0] = -1.0;
        m->u.compute_rsp.point_mm[1] = 2.5;
        m->u.compute_rsp.point_mm[2] = 1e-9;
        m->u.compute_rsp.content = AACMM_CONTENT_JACOBIAN;
        m->u.compute_rsp.params = 23;
        for (i = 0; i < 69; i++) {
            m->u.compute_rsp.jacobian[i] = (float)i * -0.5f;
        }
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
        m->u.compute_req.joints = 6;
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
        m->u.compute_rsp.params = 25;
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
    } else if (IS("sample_evt_t")) {
        m->type = AACMM_MSG_SAMPLE_EVT; m->seq = 19; sample_t(&m->u.sample);
    } else if (IS("measure_rsp7_tj")) {
        m->type = AACMM_MSG_MEASURE_RSP; m->seq = 20; sample_7tj(&m->u.sample);
    } else if (IS("trigger_evt7_tj")) {
        m->type = AACMM_MSG_TRIGGER_EVT; m->seq = 21;
        m->u.trigger.button = AACMM_BUTTON_UNDO; m->u.trigger.pressed = 0;
        sample_7tj(&m->u.trigger.sample);
    } else if (IS("measure_req_tj")) {
        m->type = AACMM_MSG_MEASURE_REQ; m->seq = 22;
        m->u.measure.content = AACMM_CONTENT_JACOBIAN | AACMM_CONTENT_TEMPERATURES;
    } else if (IS("stream_start_req_t")) {
        m->type = AACMM_MSG_STREAM_START_REQ; m->seq = 23;
        m->u.stream.rate_hz = 100; m->u.stream.content = AACMM_CONTENT_TEMPERATURES;
    } else if (IS("compute_req_tj")) {
        static const int16_t temp[6] = {-4000, 8500, 2000, 2001, 0, -1};
        m->type = AACMM_MSG_COMPUTE_REQ; m->seq = 24;
        m->u.compute_req.content = AACMM_CONTENT_JACOBIAN | AACMM_CONTENT_TEMPERATURES;
        m->u.compute_req.joints = 6;
        for (i = 0; i < 6; i++) {
            m->u.compute_req.counts[i] = (uint32_t)(11 * (i + 1));
        }
        memcpy(m->u.compute_req.temp, temp, sizeof temp);
    } else if (IS("compute_rsp_t")) {
        m->type = AACMM_MSG_COMPUTE_RSP; m->seq = 24;
        m->u.compute_rsp.status = 1;
        m->u.compute_rsp.point_mm[0] = 100.25;
        m->u.compute_rsp.point_mm[1] = -200.5;
        m->u.compute_rsp.point_mm[2] = 300.125;
        m->u.compute_rsp.content = AACMM_CONTENT_TEMPERATURES;
        m->u.compute_rsp.params = 25;
    } else if (IS("diag_rsp") || IS("diag_rsp7") || IS("diag_rsp_tf")) {
        static const aacmm_diag_joint_t joints[6] = {
            {1, 32, 0, 0u, 0u},         {1, 26, 1, 12u, 3u}, {2, 20, 6, 1u, 0u},
            {3, 13, 3, 0xFFFFFFFFu, 0u}, {0, 0, 7, 2u, 0u},  {1, 1, 8, 1u, 0xFFFFFFFFu},
        };
        aacmm_msg_diag_t *d = &m->u.diag;
        m->type = AACMM_MSG_DIAG_RSP; m->seq = IS("diag_rsp") ? 12 : IS("diag_rsp7") ? 18 : 25;
        d->storage_kind = AACMM_STORAGE_KIND_FLASH; d->storage_flags = AACMM_STORAGE_PERSISTENT;
        d->slot_state[0] = AACMM_SLOT_NEWEST; d->slot_state[1] = AACMM_SLOT_BAD_CRC;
        d->slot_generation[0] = 0x01020304u; d->slot_generation[1] = 0xFFFFFFFFu;
        d->storage_errors = 2u; d->storage_bad_records = 1u;
        d->reset_cause = AACMM_RESET_FAULT; d->reset_raw = 4u; d->fault_pc = 0x12A6u;
        d->boot_count = 3u; d->watchdog_ms = 1000u; d->uptime_us = 0x123456789ull;
        d->encoder_faults = 17u; d->serial_frames_bad = 0x80000000u;
        d->samples_dropped = 5u; d->samples_late = 6u;
        memcpy(d->joint, joints, sizeof joints);
        d->joints = 6;
        d->temp_faults = IS("diag_rsp_tf") ? 0x89ABCDEFu : 0u;
        if (IS("diag_rsp7")) {
            d->joints = 7;
            d->joint[6].interface = 2; d->joint[6].bits = 24; d->joint[6].last_fault = 5;
            d->joint[6].faults = 9u; d->joint[6].warnings = 10u;
        }
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
        a->content != b->content || a->joints != b->joints || a->params != b->params ||
        memcmp(a->counts, b->counts, sizeof a->counts) != 0 ||
        memcmp(a->point_100nm, b->point_100nm, sizeof a->point_100nm) != 0) {
        return 0;
    }
    if ((a->content & AACMM_CONTENT_TEMPERATURES) != 0u &&
        memcmp(a->temp, b->temp, sizeof a->temp) != 0) {
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
               a->can_node_id == b->can_node_id && a->joints == b->joints &&
               a->params == b->params;
    }
    case AACMM_MSG_SET_PARAMS_REQ:
    case AACMM_MSG_GET_PARAMS_RSP: {
        const aacmm_param_set_t *a = &x->u.params;
        const aacmm_param_set_t *b = &y->u.params;
        size_t n = a->enc.joints;
        return memcmp(&a->arm, &b->arm, sizeof a->arm) == 0 && a->enc.joints == b->enc.joints &&
               n <= (size_t)AACMM_JOINTS_MAX &&
               memcmp(a->enc.counts_per_rev, b->enc.counts_per_rev, n * sizeof(uint64_t)) == 0 &&
               memcmp(a->enc.zero_offset_counts, b->enc.zero_offset_counts,
                      n * sizeof(uint32_t)) == 0 &&
               memcmp(a->enc.direction, b->enc.direction, n) == 0 &&
               memcmp(&a->err, &b->err, sizeof a->err) == 0;
    }
    case AACMM_MSG_SET_PARAMS_RSP:
    case AACMM_MSG_SAVE_PARAMS_RSP:
    case AACMM_MSG_RESTORE_DEFAULTS_RSP:
        return x->u.param_crc.param_crc32 == y->u.param_crc.param_crc32;
    case AACMM_MSG_MEASURE_REQ:
        return x->u.measure.content == y->u.measure.content;
    case AACMM_MSG_COMPUTE_REQ:
        return x->u.compute_req.content == y->u.compute_req.content &&
               x->u.compute_req.joints == y->u.compute_req.joints &&
               memcmp(x->u.compute_req.counts, y->u.compute_req.counts,
                      sizeof x->u.compute_req.counts) == 0 &&
               ((x->u.compute_req.content & AACMM_CONTENT_TEMPERATURES) == 0u ||
                memcmp(x->u.compute_req.temp, y->u.compute_req.temp,
                       sizeof x->u.compute_req.temp) == 0);
    case AACMM_MSG_COMPUTE_RSP: {
        const aacmm_msg_compute_rsp_t *a = &x->u.compute_rsp;
        const aacmm_msg_compute_rsp_t *b = &y->u.compute_rsp;
        if (a->status != b->status || a->content != b->content || a->params != b->params ||
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
            a->samples_dropped != b->samples_dropped || a->samples_late != b->samples_late ||
            a->temp_faults != b->temp_faults) {
            return 0;
        }
        if (a->joints != b->joints || a->joints > AACMM_JOINTS_MAX) {
            return 0;
        }
        for (k = 0; k < a->joints; k++) {
            const aacmm_diag_joint_t *p = &a->joint[k];
            const aacmm_diag_joint_t *q = &b->joint[k];
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
