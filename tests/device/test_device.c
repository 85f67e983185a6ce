/*
 * CMocka tests of the device application against a fake in-memory platform
 * (fake_platform.h), of the parameter storage, and of the simulated arm.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "aacmm/crc32.h"
#include "aacmm/device.h"
#include "aacmm/frame.h"
#include "aacmm/isotp.h"
#include "aacmm/proto.h"
#include "aacmm/proto_can.h"
#include "aacmm_sim.h"
#include "fake_platform.h"

#ifdef AACMM_DEVICE_KIN_FIXED
#define KIN_FLAGS AACMM_BUILD_KIN_FIXED
#else
#define KIN_FLAGS 0u
#endif

static fake_t F;
static aacmm_device_t D;
static aacmm_platform_t PF;
static uint8_t TXQ[64 * 1024];
static aacmm_device_config_t CFG;

/* Host-side reader of the serial output. */
static aacmm_deframer_t host_rx;
static size_t host_pos;
static aacmm_msg_t M; /* last message read */

/* ------------------------------------------------------------------------ */
/* helpers                                                                   */
/* ------------------------------------------------------------------------ */

static void setup_links(int serial, int can, int storage, int button, int keep_storage)
{
    uint8_t saved[AACMM_STORE_BYTES];
    if (keep_storage) {
        memcpy(saved, F.storage, sizeof saved);
    }
    fake_init(&F);
    if (keep_storage) {
        memcpy(F.storage, saved, sizeof saved);
    }
    fake_platform(&F, &PF, serial, can, storage, button);
    memset(&CFG, 0, sizeof CFG);
    CFG.serial_number = 77u;
    CFG.can_node_id = 3u;
    CFG.serial_txq = TXQ;
    CFG.serial_txq_bytes = sizeof TXQ;
    aacmm_deframer_init(&host_rx);
    host_pos = 0;
}

static void boot(void)
{
    assert_int_equal(aacmm_device_init(&D, &CFG, &PF), AACMM_OK);
}

static int setup_default(void **state)
{
    (void)state;
    setup_links(1, 1, 1, 1, 0);
    boot();
    return 0;
}

static void send_body(const uint8_t *body, size_t len)
{
    size_t n = 0;
    assert_true(F.rx_len + AACMM_FRAME_MAX_WIRE <= sizeof F.rx);
    assert_int_equal(aacmm_frame_encode(body, len, F.rx + F.rx_len, sizeof F.rx - F.rx_len, &n),
                     AACMM_OK);
    F.rx_len += n;
}

static void send_msg(const aacmm_msg_t *m)
{
    uint8_t body[AACMM_PROTO_MAX_BODY];
    size_t n = 0;
    assert_int_equal(aacmm_msg_encode(m, body, sizeof body, &n), AACMM_OK);
    send_body(body, n);
}

static void send_simple(uint8_t type, uint8_t seq)
{
    aacmm_msg_t m;
    memset(&m, 0, sizeof m);
    m.type = type;
    m.seq = seq;
    send_msg(&m);
}

static void send_set_params(const aacmm_param_set_t *set, uint8_t seq)
{
    aacmm_msg_t m;
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_SET_PARAMS_REQ;
    m.seq = seq;
    m.u.params = *set;
    send_msg(&m);
}

/* Next message from the serial output into M: 1, or 0 when none is left. */
static int next_msg(void)
{
    while (host_pos < F.tx_len) {
        const uint8_t *body = NULL;
        size_t len = 0;
        host_pos += aacmm_deframer_feed(&host_rx, F.tx + host_pos, F.tx_len - host_pos, &body, &len);
        if (body != NULL) {
            assert_int_equal(aacmm_msg_decode(body, len, &M), AACMM_OK);
            return 1;
        }
    }
    return 0;
}

/* Poll, then expect exactly one message of type with seq. */
static void expect_response(uint8_t type, uint8_t seq)
{
    aacmm_device_poll(&D);
    assert_true(next_msg());
    assert_int_equal(M.type, type);
    assert_int_equal(M.seq, seq);
}

static void expect_error(aacmm_status_t st, uint8_t req_type, uint8_t seq)
{
    expect_response(AACMM_MSG_ERROR_RSP, seq);
    assert_int_equal(M.u.error.status, st);
    assert_int_equal(M.u.error.request_type, req_type);
}

/* SET_PARAMS of ``s``, taken (the response checked). */
static void set_params(const aacmm_param_set_t *s, uint8_t seq)
{
    send_set_params(s, seq);
    expect_response(AACMM_MSG_SET_PARAMS_RSP, seq);
}

static void default_set(aacmm_param_set_t *s)
{
    assert_int_equal(aacmm_param_set_default(s), AACMM_OK);
}

static void other_set(aacmm_param_set_t *s, double l_mm)
{
    default_set(s);
    s->arm.tip_mm[2] = l_mm;
    s->arm.d_mm[2] = 790.0;
    s->enc.zero_offset_counts[1] = 12345u;
}

static uint32_t set_crc(const aacmm_param_set_t *s)
{
    uint32_t crc = 0;
    assert_int_equal(aacmm_param_set_crc32(s, &crc), AACMM_OK);
    return crc;
}

static void advance(uint64_t us)
{
    F.now_us += us;
}

/* ------------------------------------------------------------------------ */
/* init                                                                      */
/* ------------------------------------------------------------------------ */

static void test_init_errors(void **state)
{
    aacmm_param_set_t bad;
    (void)state;
    setup_links(1, 1, 1, 1, 0);
    assert_int_equal(aacmm_device_init(NULL, &CFG, &PF), AACMM_ERR_NULL);
    assert_int_equal(aacmm_device_init(&D, NULL, &PF), AACMM_ERR_NULL);
    assert_int_equal(aacmm_device_init(&D, &CFG, NULL), AACMM_ERR_NULL);
    PF.time_us = NULL;
    assert_int_equal(aacmm_device_init(&D, &CFG, &PF), AACMM_ERR_NULL);
    fake_platform(&F, &PF, 1, 1, 1, 1);
    PF.read_encoders = NULL;
    assert_int_equal(aacmm_device_init(&D, &CFG, &PF), AACMM_ERR_NULL);
    fake_platform(&F, &PF, 0, 0, 1, 1);
    assert_int_equal(aacmm_device_init(&D, &CFG, &PF), AACMM_ERR_RANGE); /* no link */
    fake_platform(&F, &PF, 1, 0, 1, 1);
    CFG.serial_txq = NULL;
    assert_int_equal(aacmm_device_init(&D, &CFG, &PF), AACMM_ERR_NULL);
    CFG.serial_txq = TXQ;
    CFG.serial_txq_bytes = AACMM_DEVICE_SERIAL_TXQ_MIN - 1u;
    assert_int_equal(aacmm_device_init(&D, &CFG, &PF), AACMM_ERR_RANGE);
    CFG.serial_txq_bytes = sizeof TXQ;
    CFG.can_node_id = 16u;
    assert_int_equal(aacmm_device_init(&D, &CFG, &PF), AACMM_ERR_RANGE);
    CFG.can_node_id = 15u;
    default_set(&bad);
    bad.arm.d_mm[0] = 20000.0;
    CFG.defaults = &bad;
    assert_int_equal(aacmm_device_init(&D, &CFG, &PF), AACMM_ERR_RANGE);
    bad.arm.d_mm[0] = 300.0;
    bad.enc.direction[0] = 0;
    assert_int_equal(aacmm_device_init(&D, &CFG, &PF), AACMM_ERR_RANGE);
    CFG.defaults = NULL;
    assert_int_equal(aacmm_device_init(&D, &CFG, &PF), AACMM_OK);
    /* CAN only works without a serial queue. */
    fake_platform(&F, &PF, 0, 1, 0, 0);
    CFG.serial_txq = NULL;
    CFG.serial_txq_bytes = 0;
    assert_int_equal(aacmm_device_init(&D, &CFG, &PF), AACMM_OK);
    assert_int_equal(aacmm_device_build_flags(&D) & (AACMM_BUILD_SERIAL | AACMM_BUILD_CAN),
                     AACMM_BUILD_CAN);
    assert_int_equal(aacmm_device_poll(NULL), AACMM_ERR_NULL);
    assert_null(aacmm_device_counters(NULL));
}

/* ------------------------------------------------------------------------ */
/* every request over serial                                                 */
/* ------------------------------------------------------------------------ */

static void test_ping_info(void **state)
{
    aacmm_msg_t m;
    aacmm_param_set_t def;
    (void)state;
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_PING_REQ;
    m.seq = 9;
    m.u.ping.token = 0xCAFEF00Du;
    send_msg(&m);
    expect_response(AACMM_MSG_PING_RSP, 9);
    assert_int_equal(M.u.ping.token, 0xCAFEF00Du);

    send_simple(AACMM_MSG_INFO_REQ, 10);
    expect_response(AACMM_MSG_INFO_RSP, 10);
    default_set(&def);
    assert_int_equal(M.u.info.protocol_version, AACMM_PROTO_VERSION);
    assert_int_equal(M.u.info.fw_major, AACMM_FW_MAJOR);
    assert_int_equal(M.u.info.fw_minor, AACMM_FW_MINOR);
    assert_int_equal(M.u.info.build_flags,
                     KIN_FLAGS | AACMM_BUILD_JACOBIAN | AACMM_BUILD_SERIAL | AACMM_BUILD_CAN);
    assert_int_equal(M.u.info.param_crc32, set_crc(&def));
    assert_int_equal(M.u.info.param_source, AACMM_PARAM_SOURCE_DEFAULTS);
    assert_int_equal(M.u.info.storage_state, AACMM_STORAGE_EMPTY);
    assert_int_equal(M.u.info.max_body_bytes, AACMM_PROTO_MAX_BODY);
    assert_int_equal(M.u.info.serial_number, 77u);
    assert_int_equal(M.u.info.can_node_id, 3u);
    assert_false(next_msg());
    assert_int_equal(aacmm_device_counters(&D)->requests, 2u);
}

static void test_params_set_get_restore(void **state)
{
    aacmm_param_set_t s;
    (void)state;
    other_set(&s, 150.0);
    set_params(&s, 1);
    assert_int_equal(M.u.param_crc.param_crc32, set_crc(&s));

    send_simple(AACMM_MSG_GET_PARAMS_REQ, 2);
    expect_response(AACMM_MSG_GET_PARAMS_RSP, 2);
    assert_int_equal(set_crc(&M.u.params), set_crc(&s));
    assert_true(M.u.params.arm.tip_mm[2] > 149.9 && M.u.params.arm.tip_mm[2] < 150.1);

    send_simple(AACMM_MSG_INFO_REQ, 3);
    expect_response(AACMM_MSG_INFO_RSP, 3);
    assert_int_equal(M.u.info.param_crc32, set_crc(&s));
    /* #14.1: a set that was not saved is not "from storage". */
    assert_int_equal(M.u.info.param_source, AACMM_PARAM_SOURCE_HOST);
    assert_int_equal(M.u.info.storage_state, AACMM_STORAGE_EMPTY);

    send_simple(AACMM_MSG_RESTORE_DEFAULTS_REQ, 4);
    expect_response(AACMM_MSG_RESTORE_DEFAULTS_RSP, 4);
    default_set(&s);
    assert_int_equal(M.u.param_crc.param_crc32, set_crc(&s));
    send_simple(AACMM_MSG_INFO_REQ, 5);
    expect_response(AACMM_MSG_INFO_RSP, 5);
    assert_int_equal(M.u.info.param_source, AACMM_PARAM_SOURCE_DEFAULTS);
}

/* The device's point (wire units or mm) and Jacobian against the float core:
 * bit for bit on the float backend; on the fixed-point backend against the
 * double-precision core, within 1 wire unit (0.1 um) / 1e-9 mm and 1e-3 of
 * the Jacobian (float32 output of an exact Q48 value vs float32 core). */
static void check_point_and_jacobian(const int32_t *wire, const double *mm, const float *jac_got,
                                     const float p32[3], const float jac32[AACMM_JAC_SIZE],
                                     const uint32_t counts[AACMM_JOINTS])
{
    int i;
#ifndef AACMM_DEVICE_KIN_FIXED
    (void)counts;
    for (i = 0; i < 3; i++) {
        if (wire != NULL) {
            assert_int_equal(wire[i], aacmm_point_mm_to_wire((double)p32[i], NULL));
        }
        if (mm != NULL) {
            double want = (double)p32[i];
            assert_memory_equal(&mm[i], &want, sizeof want);
        }
    }
    assert_memory_equal(jac_got, jac32, AACMM_JAC_SIZE * sizeof(float));
#else
    aacmm_params_f64_t p64;
    aacmm_model_f64_t m64;
    aacmm_encoder_config_t enc;
    double th[AACMM_JOINTS];
    double p[3];
    double jac[AACMM_JAC_SIZE];
    (void)p32;
    (void)jac32;
    assert_int_equal(aacmm_params_default_f64(&p64), AACMM_OK);
    assert_int_equal(aacmm_model_init_f64(&m64, &p64), AACMM_OK);
    assert_int_equal(aacmm_encoder_default(&enc), AACMM_OK);
    assert_int_equal(aacmm_encoder_to_angles_f64(&enc, counts, th), AACMM_OK);
    assert_int_equal(aacmm_point_jacobian_f64(&m64, th, p, jac), AACMM_OK);
    for (i = 0; i < 3; i++) {
        if (wire != NULL) {
            int32_t want = aacmm_point_mm_to_wire(p[i], NULL);
            assert_true(wire[i] - want <= 1 && want - wire[i] <= 1);
        }
        if (mm != NULL) {
            assert_true(mm[i] - p[i] < 1e-6 && p[i] - mm[i] < 1e-6);
        }
    }
    for (i = 0; i < AACMM_JAC_SIZE; i++) {
        double d = (double)jac_got[i] - jac[i];
        assert_true(d < 1e-3 && d > -1e-3);
    }
#endif
}

/* Issue 26: a 7-joint arm model (modified DH on the wrist, a beta, a tip
 * vector) set with SET_PARAMS: INFO reports N and P, samples and COMPUTE carry
 * 7 counts and the 3 x P Jacobian, equal to the core's own evaluation of the
 * same arm (the float backend bit for bit in single precision; the fixed
 * backend within the fixed path's bounds of the double-precision core). */
static void test_seven_joint_arm_model(void **state)
{
    aacmm_msg_t m;
    aacmm_param_set_t set;
    static const uint32_t counts[7] = {0x12345678u, 0xE0000000u, 0x30000000u, 0xF0000000u,
                                       0x2AAAAAABu, 0x9ABCDEF0u, 0x40000000u};
    int i;
    int p_cols;
    (void)state;
    memset(&set, 0, sizeof set);
    set.arm.shape.joints = 7u;
    set.arm.shape.tip = (uint8_t)AACMM_TIP_XYZ;
    set.arm.shape.convention[4] = set.arm.shape.convention[5] = set.arm.shape.convention[6] =
        (uint8_t)AACMM_DH_MODIFIED;
    set.arm.shape.beta[2] = 1u;
    for (i = 0; i < 7; i++) {
        set.arm.alpha_rad[i] = (i % 2 == 0) ? 1.5707963267948966 : -1.5707963267948966;
        set.arm.d_mm[i] = 100.0 + 50.0 * i;
        set.arm.a_mm[i] = 10.0 * i;
        set.arm.theta_offset_rad[i] = 0.01 * i;
    }
    set.arm.beta_rad[2] = 0.0015;
    set.arm.tip_mm[0] = 1.5;
    set.arm.tip_mm[1] = -2.0;
    set.arm.tip_mm[2] = 110.0;
    assert_int_equal(aacmm_arm_encoders_default(&set.enc, 7), AACMM_OK);
    p_cols = aacmm_shape_params(&set.arm.shape);
    assert_int_equal(p_cols, 28 + 1 + 3);
    set_params(&set, 30);
    send_simple(AACMM_MSG_INFO_REQ, 31);
    expect_response(AACMM_MSG_INFO_RSP, 31);
    assert_int_equal(M.u.info.joints, 7);
    assert_int_equal(M.u.info.params, p_cols);

    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_COMPUTE_REQ;
    m.seq = 32;
    m.u.compute_req.content = AACMM_CONTENT_JACOBIAN;
    m.u.compute_req.joints = 7;
    memcpy(m.u.compute_req.counts, counts, sizeof counts);
    send_msg(&m);
    expect_response(AACMM_MSG_COMPUTE_RSP, 32);
    assert_int_equal(M.u.compute_rsp.params, p_cols);
    {
#ifndef AACMM_DEVICE_KIN_FIXED
        aacmm_arm_f32_t a32;
        aacmm_model_f32_t m32;
        aacmm_arm_encoders_t e;
        float th[7];
        float pt[3];
        float jac[AACMM_JAC_SIZE_MAX];
        a32.shape = set.arm.shape;
        for (i = 0; i < AACMM_JOINTS_MAX; i++) {
            a32.theta_offset_rad[i] = (float)set.arm.theta_offset_rad[i];
            a32.alpha_rad[i] = (float)set.arm.alpha_rad[i];
            a32.d_mm[i] = (float)set.arm.d_mm[i];
            a32.a_mm[i] = (float)set.arm.a_mm[i];
            a32.beta_rad[i] = (float)set.arm.beta_rad[i];
        }
        for (i = 0; i < 3; i++) {
            a32.tip_mm[i] = (float)set.arm.tip_mm[i];
        }
        assert_int_equal(aacmm_model_init_arm_f32(&m32, &a32), AACMM_OK);
        e = set.enc;
        assert_int_equal(aacmm_arm_encoders_to_angles_f32(&e, counts, th), AACMM_OK);
        assert_int_equal(aacmm_point_jacobian_f32(&m32, th, pt, jac), AACMM_OK);
        for (i = 0; i < 3; i++) {
            double want = (double)pt[i];
            assert_memory_equal(&M.u.compute_rsp.point_mm[i], &want, sizeof want);
        }
        assert_memory_equal(M.u.compute_rsp.jacobian, jac, (size_t)(3 * p_cols) * sizeof(float));
#else
        aacmm_model_f64_t m64;
        double th[7];
        double pt[3];
        double jac[AACMM_JAC_SIZE_MAX];
        assert_int_equal(aacmm_model_init_arm_f64(&m64, &set.arm), AACMM_OK);
        assert_int_equal(aacmm_arm_encoders_to_angles_f64(&set.enc, counts, th), AACMM_OK);
        assert_int_equal(aacmm_point_jacobian_f64(&m64, th, pt, jac), AACMM_OK);
        for (i = 0; i < 3; i++) {
            double d = M.u.compute_rsp.point_mm[i] - pt[i];
            assert_true(d < 1e-4 && d > -1e-4);
        }
        for (i = 0; i < 3 * p_cols; i++) {
            double d = (double)M.u.compute_rsp.jacobian[i] - jac[i];
            assert_true(d < 1e-3 && d > -1e-3);
        }
#endif
    }
    /* the paper's six counts are refused: another arm's */
    m.seq = 33;
    m.u.compute_req.joints = 6;
    send_msg(&m);
    expect_error(AACMM_ERR_RANGE, AACMM_MSG_COMPUTE_REQ, 33);
    /* samples carry the model's 7 counts and P */
    memset(F.counts, 0, sizeof F.counts);
    send_simple(AACMM_MSG_MEASURE_REQ, 34);
    expect_response(AACMM_MSG_MEASURE_RSP, 34);
    assert_int_equal(M.u.sample.joints, 7);
    assert_int_equal(M.u.sample.params, p_cols);
    /* the thermal block needs link temperatures, which this platform does
     * not read: refused (never a point at the wrong lengths) */
    set.err.thermal = 1u;
    set.err.cte[0] = 2300;
    set.err.ref_temp = 2000;
    m.type = AACMM_MSG_SET_PARAMS_REQ;
    m.seq = 35;
    m.u.params = set;
    send_msg(&m);
    expect_error(AACMM_ERR_UNSUPPORTED, AACMM_MSG_SET_PARAMS_REQ, 35);
    /* harmonics on every joint (K = 2): computed (test_error_model_applied) */
    memset(&set.err, 0, sizeof set.err);
    for (i = 0; i < 7; i++) {
        set.err.harmonics[i] = 2u;
        set.err.harm_cos[i][0] = (int16_t)(3000 - 700 * i);
        set.err.harm_sin[i][1] = (int16_t)(-1200 + 300 * i);
    }
    m.seq = 36;
    m.u.params = set;
    send_msg(&m);
    expect_response(AACMM_MSG_SET_PARAMS_RSP, 36);
}

static void save_via_request(uint8_t seq);

/* The reference for a corrected point, computed apart from the core's error
 * model: libm's cos and sin of k q (no recurrence), in double, then the
 * double-precision chain. */
static void reference_point(const aacmm_param_set_t *set, const uint32_t *counts, double p[3])
{
    aacmm_model_f64_t m64;
    double th[AACMM_JOINTS_MAX];
    int i;
    int k;
    int n = (int)set->arm.shape.joints;
    assert_int_equal(aacmm_model_init_arm_f64(&m64, &set->arm), AACMM_OK);
    assert_int_equal(aacmm_arm_encoders_to_angles_f64(&set->enc, counts, th), AACMM_OK);
    for (i = 0; i < n; i++) {
        double q = th[i];
        for (k = 1; k <= (int)set->err.harmonics[i]; k++) {
            th[i] += 1e-7 * ((double)set->err.harm_cos[i][k - 1] * cos(k * q) +
                             (double)set->err.harm_sin[i][k - 1] * sin(k * q));
        }
    }
    assert_int_equal(aacmm_point_f64(&m64, th, p), AACMM_OK);
}

/* SET_PARAMS *set, then COMPUTE and MEASURE at counts: the device's points
 * agree with the reference within tol_mm (COMPUTE) and tol_mm + the wire's
 * 0.05 um rounding (MEASURE); returns the largest COMPUTE difference. */
static double check_corrected(const aacmm_param_set_t *set, const uint32_t *counts, double tol_mm)
{
    aacmm_msg_t m;
    double want[3];
    double worst = 0.0;
    int i;
    int n = (int)set->arm.shape.joints;
    reference_point(set, counts, want);
    set_params(set, 50);
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_COMPUTE_REQ;
    m.seq = 51;
    m.u.compute_req.content = AACMM_CONTENT_JACOBIAN;
    m.u.compute_req.joints = (uint8_t)n;
    memcpy(m.u.compute_req.counts, counts, sizeof(uint32_t) * (size_t)n);
    send_msg(&m);
    expect_response(AACMM_MSG_COMPUTE_RSP, 51);
    assert_int_equal(M.u.compute_rsp.status & AACMM_SAMPLE_POINT_VALID, AACMM_SAMPLE_POINT_VALID);
    for (i = 0; i < 3; i++) {
        double d = fabs(M.u.compute_rsp.point_mm[i] - want[i]);
        assert_true(d <= tol_mm);
        worst = d > worst ? d : worst;
    }
    /* the fake port has six encoders (a seventh reads 0: the callers use 0) */
    memcpy(F.counts, counts, sizeof F.counts);
    send_simple(AACMM_MSG_MEASURE_REQ, 52);
    expect_response(AACMM_MSG_MEASURE_RSP, 52);
    assert_int_equal(M.u.sample.status & AACMM_SAMPLE_POINT_VALID, AACMM_SAMPLE_POINT_VALID);
    for (i = 0; i < 3; i++) {
        double got = (double)M.u.sample.point_100nm[i] * 1e-4;
        assert_true(fabs(got - want[i]) <= tol_mm + 5e-5);
    }
    return worst;
}

static void test_error_model_applied(void **state)
{
#ifdef AACMM_DEVICE_KIN_FIXED
    const double tol = 1e-4; /* the fixed path's class */
#else
    const double tol = 1e-3; /* the f32 class */
#endif
    aacmm_param_set_t set;
    aacmm_param_set_t plain;
    uint32_t counts[AACMM_JOINTS_MAX] = {0};
    double want[3];
    double moved = 0.0;
    int i;
    int pose;
    (void)state;
    default_set(&set);
    plain = set;
    for (i = 0; i < 6; i++) {
        set.err.harmonics[i] = 2u;
        set.err.harm_cos[i][0] = (int16_t)(2500 - 900 * i); /* up to 0.25 mrad */
        set.err.harm_sin[i][0] = (int16_t)(-1500 + 450 * i);
        set.err.harm_cos[i][1] = (int16_t)(400 + 100 * i);
        set.err.harm_sin[i][1] = (int16_t)(-32768 + 13000 * (i % 3)); /* the i16 extremes */
    }
    for (pose = 0; pose < 5; pose++) {
        for (i = 0; i < 6; i++) {
            counts[i] = (uint32_t)(((uint64_t)set.enc.counts_per_rev[i] *
                                    (uint64_t)(37u * (unsigned)pose + 11u * (unsigned)i + 3u)) /
                                   97u);
        }
        (void)check_corrected(&set, counts, tol);
        /* the correction moved the point (by far more than the class) */
        reference_point(&plain, counts, want);
        for (i = 0; i < 3; i++) {
            double d = fabs((double)M.u.sample.point_100nm[i] * 1e-4 - want[i]);
            moved = d > moved ? d : moved;
        }
    }
    assert_true(moved > 0.1);
    /* GET_PARAMS gives the set back, error model included */
    send_simple(AACMM_MSG_GET_PARAMS_REQ, 53);
    expect_response(AACMM_MSG_GET_PARAMS_RSP, 53);
    assert_memory_equal(&M.u.params.err, &set.err, sizeof set.err);
    /* stored like the rest: saved, restarted on the same storage, the same
     * set (CRC) and the same corrected point, bit for bit */
    {
        aacmm_msg_t c;
        double before[3];
        memset(&c, 0, sizeof c);
        c.type = AACMM_MSG_COMPUTE_REQ;
        c.seq = 57;
        c.u.compute_req.joints = 6;
        memcpy(c.u.compute_req.counts, counts, sizeof counts);
        send_msg(&c);
        expect_response(AACMM_MSG_COMPUTE_RSP, 57);
        memcpy(before, M.u.compute_rsp.point_mm, sizeof before);
        save_via_request(58);
        assert_int_equal(M.u.param_crc.param_crc32, set_crc(&set));
        setup_links(1, 1, 1, 1, 1);
        boot();
        send_simple(AACMM_MSG_INFO_REQ, 59);
        expect_response(AACMM_MSG_INFO_RSP, 59);
        assert_int_equal(M.u.info.param_source, AACMM_PARAM_SOURCE_STORAGE);
        assert_int_equal(M.u.info.param_crc32, set_crc(&set));
        send_msg(&c);
        expect_response(AACMM_MSG_COMPUTE_RSP, 57);
        assert_memory_equal(M.u.compute_rsp.point_mm, before, sizeof before);
    }
    /* K = 0 again: today's point, bit for bit (the plain core path) */
    {
        aacmm_msg_t m;
        aacmm_msg_t before;
        memset(&m, 0, sizeof m);
        m.type = AACMM_MSG_RESTORE_DEFAULTS_REQ;
        m.seq = 54;
        send_msg(&m);
        expect_response(AACMM_MSG_RESTORE_DEFAULTS_RSP, 54);
        aacmm_msg_t c;
        memset(&c, 0, sizeof c);
        c.type = AACMM_MSG_COMPUTE_REQ;
        c.seq = 55;
        c.u.compute_req.content = AACMM_CONTENT_JACOBIAN;
        c.u.compute_req.joints = 6;
        memcpy(c.u.compute_req.counts, counts, sizeof counts);
        send_msg(&c);
        expect_response(AACMM_MSG_COMPUTE_RSP, 55);
        before = M;
        m.type = AACMM_MSG_SET_PARAMS_REQ;
        m.seq = 56;
        m.u.params = plain;
        send_msg(&m);
        expect_response(AACMM_MSG_SET_PARAMS_RSP, 56);
        send_msg(&c);
        expect_response(AACMM_MSG_COMPUTE_RSP, 55);
        assert_memory_equal(M.u.compute_rsp.point_mm, before.u.compute_rsp.point_mm,
                            sizeof M.u.compute_rsp.point_mm);
        assert_memory_equal(M.u.compute_rsp.jacobian, before.u.compute_rsp.jacobian,
                            sizeof M.u.compute_rsp.jacobian);
    }
}

/* A 7-axis arm (modified DH on the wrist, a beta, a tip vector) with K = 2
 * on every joint. */
static void test_error_model_seven_axes(void **state)
{
#ifdef AACMM_DEVICE_KIN_FIXED
    const double tol = 1e-4;
#else
    const double tol = 1e-3;
#endif
    aacmm_param_set_t set;
    uint32_t counts[AACMM_JOINTS_MAX];
    int i;
    int pose;
    (void)state;
    memset(&set, 0, sizeof set);
    set.arm.shape.joints = 7u;
    set.arm.shape.tip = (uint8_t)AACMM_TIP_XYZ;
    set.arm.shape.convention[4] = set.arm.shape.convention[5] = set.arm.shape.convention[6] =
        (uint8_t)AACMM_DH_MODIFIED;
    set.arm.shape.beta[2] = 1u;
    for (i = 0; i < 7; i++) {
        set.arm.alpha_rad[i] = (i % 2 == 0) ? 1.5707963267948966 : -1.5707963267948966;
        set.arm.d_mm[i] = 100.0 + 50.0 * i;
        set.arm.a_mm[i] = 10.0 * i;
        set.arm.theta_offset_rad[i] = 0.01 * i;
        set.err.harmonics[i] = 2u;
        set.err.harm_cos[i][0] = (int16_t)(3000 - 700 * i);
        set.err.harm_sin[i][0] = (int16_t)(200 * i - 500);
        set.err.harm_cos[i][1] = (int16_t)(-800 + 90 * i);
        set.err.harm_sin[i][1] = (int16_t)(-1200 + 300 * i);
    }
    set.arm.beta_rad[2] = 0.0015;
    set.arm.tip_mm[0] = 1.5;
    set.arm.tip_mm[1] = -2.0;
    set.arm.tip_mm[2] = 110.0;
    assert_int_equal(aacmm_arm_encoders_default(&set.enc, 7), AACMM_OK);
    for (pose = 0; pose < 5; pose++) {
        for (i = 0; i < 6; i++) {
            counts[i] = (uint32_t)(((uint64_t)set.enc.counts_per_rev[i] *
                                    (uint64_t)(29u * (unsigned)pose + 13u * (unsigned)i + 5u)) /
                                   89u);
        }
        counts[6] = 0u; /* the fake port's seventh joint */
        (void)check_corrected(&set, counts, tol);
    }
}

static void test_measure_and_compute(void **state)
{
    aacmm_msg_t m;
    aacmm_model_f32_t model;
    aacmm_params_f32_t p32;
    aacmm_encoder_config_t enc;
    float theta[AACMM_JOINTS];
    float p[3];
    float jac[AACMM_JAC_SIZE];
    static const uint32_t counts[AACMM_JOINTS] = {0x12345678u, 0xE0000000u, 0x30000000u,
                                                  0xF0000000u, 0x2AAAAAABu, 0x9ABCDEF0u};
    (void)state;
    assert_int_equal(aacmm_params_default_f32(&p32), AACMM_OK);
    assert_int_equal(aacmm_model_init_f32(&model, &p32), AACMM_OK);
    assert_int_equal(aacmm_encoder_default(&enc), AACMM_OK);
    assert_int_equal(aacmm_encoder_to_angles_f32(&enc, counts, theta), AACMM_OK);
    assert_int_equal(aacmm_point_jacobian_f32(&model, theta, p, jac), AACMM_OK);

    memcpy(F.counts, counts, sizeof counts);
    F.now_us = 5000000u;
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_MEASURE_REQ;
    m.seq = 20;
    m.u.measure.content = AACMM_CONTENT_JACOBIAN;
    send_msg(&m);
    expect_response(AACMM_MSG_MEASURE_RSP, 20);
    assert_int_equal(M.u.sample.seq, 0u);
    assert_int_equal(M.u.sample.timestamp_us, 5000000u);
    assert_memory_equal(M.u.sample.counts, counts, sizeof counts);
    assert_int_equal(M.u.sample.status, AACMM_SAMPLE_POINT_VALID | AACMM_SAMPLE_PARAMS_DEFAULT);
    assert_int_equal(M.u.sample.content, AACMM_CONTENT_JACOBIAN);
    check_point_and_jacobian(M.u.sample.point_100nm, NULL, M.u.sample.jacobian, p, jac, counts);
    m.seq = 21;
    m.u.measure.content = 0;
    send_msg(&m);
    expect_response(AACMM_MSG_MEASURE_RSP, 21);
    assert_int_equal(M.u.sample.seq, 1u); /* device-wide measurement counter */
    assert_int_equal(M.u.sample.content, 0);

    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_COMPUTE_REQ;
    m.seq = 22;
    m.u.compute_req.content = AACMM_CONTENT_JACOBIAN;
    m.u.compute_req.joints = AACMM_JOINTS;
    memcpy(m.u.compute_req.counts, counts, sizeof counts);
    send_msg(&m);
    expect_response(AACMM_MSG_COMPUTE_RSP, 22);
    assert_int_equal(M.u.compute_rsp.status, AACMM_SAMPLE_POINT_VALID | AACMM_SAMPLE_PARAMS_DEFAULT);
    check_point_and_jacobian(NULL, M.u.compute_rsp.point_mm, M.u.compute_rsp.jacobian, p, jac, counts);
    assert_int_equal(F.encoder_reads, 2u); /* compute does not read the encoders */
}

static void test_stream_start_stop(void **state)
{
    aacmm_msg_t m;
    int n = 0;
    (void)state;
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_STREAM_START_REQ;
    m.seq = 30;
    m.u.stream.rate_hz = 100;
    m.u.stream.content = AACMM_CONTENT_JACOBIAN;
    send_msg(&m);
    expect_response(AACMM_MSG_STREAM_START_RSP, 30);
    assert_int_equal(M.u.stream.rate_hz, 100);
    assert_int_equal(M.u.stream.content, AACMM_CONTENT_JACOBIAN);
    /* Sample 0 goes out right after the response. */
    assert_true(next_msg());
    assert_int_equal(M.type, AACMM_MSG_SAMPLE_EVT);
    assert_int_equal(M.u.sample.seq, 0u);
    assert_int_equal(M.u.sample.content, AACMM_CONTENT_JACOBIAN);
    advance(10000u);
    aacmm_device_poll(&D);
    assert_true(next_msg());
    assert_int_equal(M.u.sample.seq, 1u);
    send_simple(AACMM_MSG_STREAM_STOP_REQ, 31);
    expect_response(AACMM_MSG_STREAM_STOP_RSP, 31);
    advance(100000u);
    aacmm_device_poll(&D);
    while (next_msg()) {
        n++;
    }
    assert_int_equal(n, 0);
}

/* ------------------------------------------------------------------------ */
/* bad requests                                                              */
/* ------------------------------------------------------------------------ */

static void test_bad_requests(void **state)
{
    uint8_t body[AACMM_PROTO_MAX_BODY];
    aacmm_msg_t m;
    size_t n = 0;
    int v;
    (void)state;
    /* Wrong version (a future one). */
    body[0] = (uint8_t)(AACMM_PROTO_VERSION + 1u);
    body[1] = AACMM_MSG_PING_REQ;
    body[2] = 40;
    memset(body + 3, 0, 4);
    send_body(body, 7);
    expect_error(AACMM_ERR_VERSION, AACMM_MSG_PING_REQ, 40);
    /* The older versions (3: before device temperatures; 2: before the
     * error model's layout; 1: six joints): the answer is an ERROR_RSP in
     * the request's own version, which that host can read (read raw here). */
    assert_int_equal(AACMM_PROTO_VERSION_PREVIOUS, 3);
    for (v = (int)AACMM_PROTO_VERSION_PREVIOUS; v >= (int)AACMM_PROTO_VERSION_OLDEST; v--) {
        const uint8_t *b = NULL;
        size_t bl = 0;
        body[0] = (uint8_t)v;
        body[2] = 39;
        send_body(body, 7);
        aacmm_device_poll(&D);
        while (b == NULL && host_pos < F.tx_len) {
            host_pos +=
                aacmm_deframer_feed(&host_rx, F.tx + host_pos, F.tx_len - host_pos, &b, &bl);
        }
        assert_non_null(b);
        assert_int_equal(bl, 6);
        assert_int_equal(b[0], v);
        assert_int_equal(b[1], AACMM_MSG_ERROR_RSP);
        assert_int_equal(b[2], 39);
        assert_int_equal((int16_t)(b[3] | (b[4] << 8)), AACMM_ERR_VERSION);
        assert_int_equal(b[5], AACMM_MSG_PING_REQ);
    }
    /* Unknown type. */
    body[0] = (uint8_t)AACMM_PROTO_VERSION;
    body[1] = 0x3E;
    body[2] = 41;
    send_body(body, 3);
    expect_error(AACMM_ERR_UNKNOWN_TYPE, 0x3E, 41);
    /* Wrong payload length. */
    body[1] = AACMM_MSG_PING_REQ;
    body[2] = 42;
    send_body(body, 5);
    expect_error(AACMM_ERR_LENGTH, AACMM_MSG_PING_REQ, 42);
    /* Stream rate out of range (raw: the encoder refuses it). */
    body[1] = AACMM_MSG_STREAM_START_REQ;
    body[2] = 43;
    body[3] = 0xE9; /* 1001 Hz */
    body[4] = 0x03;
    body[5] = 0;
    send_body(body, 6);
    expect_error(AACMM_ERR_RANGE, AACMM_MSG_STREAM_START_REQ, 43);
    /* Unknown content bit. */
    body[1] = AACMM_MSG_MEASURE_REQ;
    body[2] = 44;
    body[3] = 0x80;
    send_body(body, 4);
    expect_error(AACMM_ERR_RANGE, AACMM_MSG_MEASURE_REQ, 44);
    /* A response type sent to the device. */
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_PING_RSP;
    m.seq = 45;
    send_msg(&m);
    expect_error(AACMM_ERR_UNKNOWN_TYPE, AACMM_MSG_PING_RSP, 45);
    /* Parameters out of the core's range: d = 20 m. */
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_SET_PARAMS_REQ;
    m.seq = 46;
    default_set(&m.u.params);
    m.u.params.arm.d_mm[1] = 20000.0;
    send_msg(&m);
    expect_error(AACMM_ERR_RANGE, AACMM_MSG_SET_PARAMS_REQ, 46);
    /* NaN in a parameter (raw). */
    default_set(&m.u.params);
    m.u.params.arm.d_mm[1] = 65.5;
    assert_int_equal(aacmm_msg_encode(&m, body, sizeof body, &n), AACMM_OK);
    body[2] = 47;
    memset(body + 3 + 8 + 8 * 13, 0xFF, 8); /* d_2 := NaN (after the set's 8-byte header) */
    send_body(body, n);
    expect_error(AACMM_ERR_NOT_FINITE, AACMM_MSG_SET_PARAMS_REQ, 47);
    /* COMPUTE with a count >= cpr after a 12-bit encoder set. */
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_SET_PARAMS_REQ;
    m.seq = 48;
    default_set(&m.u.params);
    {
        int i;
        for (i = 0; i < AACMM_JOINTS; i++) {
            m.u.params.enc.counts_per_rev[i] = 4096u;
        }
    }
    send_msg(&m);
    expect_response(AACMM_MSG_SET_PARAMS_RSP, 48);
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_COMPUTE_REQ;
    m.seq = 49;
    m.u.compute_req.joints = AACMM_JOINTS;
    m.u.compute_req.counts[3] = 4096u;
    send_msg(&m);
    expect_error(AACMM_ERR_RANGE, AACMM_MSG_COMPUTE_REQ, 49);
    /* A measurement with such a count is an encoder fault, not an error. */
    F.counts[3] = 5000u;
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_MEASURE_REQ;
    m.seq = 50;
    send_msg(&m);
    expect_response(AACMM_MSG_MEASURE_RSP, 50);
    assert_true((M.u.sample.status & AACMM_SAMPLE_ENCODER_FAULT) != 0u);
    assert_true((M.u.sample.status & AACMM_SAMPLE_POINT_VALID) == 0u);
    assert_int_equal(aacmm_device_counters(&D)->encoder_faults, 1u);
    assert_int_equal(aacmm_device_counters(&D)->error_responses, 12u); /* 3 old versions */
    assert_false(next_msg());
}

static void test_garbage_and_crc_errors(void **state)
{
    static const uint8_t garbage[] = {0x13, 0x37, 0x00, 0x05, 0x11, 0x22, 0x33, 0x44, 0x00,
                                      0xFF, 0xFE, 0x01, 0x02};
    uint8_t body[7] = {AACMM_PROTO_VERSION, AACMM_MSG_PING_REQ, 60, 1, 2, 3, 4};
    size_t start;
    (void)state;
    memcpy(F.rx + F.rx_len, garbage, sizeof garbage);
    F.rx_len += sizeof garbage;
    /* A frame with a wrong CRC. */
    start = F.rx_len;
    send_body(body, sizeof body);
    F.rx[start + 3] ^= 0x40;
    /* Then a good one. */
    body[2] = 61;
    send_body(body, sizeof body);
    expect_response(AACMM_MSG_PING_RSP, 61);
    assert_int_equal(M.u.ping.token, 0x04030201u);
    assert_false(next_msg());
    assert_true(aacmm_device_serial_stats(&D)->crc_errors + aacmm_device_serial_stats(&D)->cobs_errors +
                    aacmm_device_serial_stats(&D)->runts >=
                2u);
    assert_int_equal(aacmm_device_serial_stats(&D)->frames_ok, 1u);
}

static void test_storage_unsupported(void **state)
{
    (void)state;
    setup_links(1, 0, 0, 0, 0);
    boot();
    send_simple(AACMM_MSG_SAVE_PARAMS_REQ, 70);
    expect_error(AACMM_ERR_UNSUPPORTED, AACMM_MSG_SAVE_PARAMS_REQ, 70);
    send_simple(AACMM_MSG_INFO_REQ, 71);
    expect_response(AACMM_MSG_INFO_RSP, 71);
    assert_int_equal(M.u.info.storage_state, AACMM_STORAGE_EMPTY);
    assert_int_equal(M.u.info.build_flags & AACMM_BUILD_CAN, 0u);
}

/* ------------------------------------------------------------------------ */
/* streaming cadence                                                         */
/* ------------------------------------------------------------------------ */

static void start_stream(uint16_t rate, uint8_t content)
{
    aacmm_msg_t m;
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_STREAM_START_REQ;
    m.seq = 99;
    m.u.stream.rate_hz = rate;
    m.u.stream.content = content;
    send_msg(&m);
    expect_response(AACMM_MSG_STREAM_START_RSP, 99);
}

static void test_stream_1khz_cadence(void **state)
{
    uint64_t t0;
    uint32_t expect_seq = 0;
    int k;
    (void)state;
    t0 = F.now_us;
    start_stream(1000, 0);
    for (k = 0; k <= 5000; k++) {
        if (k > 0) {
            advance(1000u);
            /* The device asks to be woken at the next sample, not later. */
            aacmm_device_poll(&D);
        }
        while (next_msg()) {
            assert_int_equal(M.type, AACMM_MSG_SAMPLE_EVT);
            assert_int_equal(M.u.sample.seq, expect_seq);
            assert_int_equal(M.u.sample.timestamp_us, t0 + 1000u * expect_seq);
            assert_int_equal(M.u.sample.status & AACMM_SAMPLE_OVERRUN, 0u);
            expect_seq++;
        }
        assert_int_equal(expect_seq, (uint32_t)k + 1u);
        assert_int_equal(aacmm_device_next_deadline_us(&D), t0 + 1000u * ((uint64_t)k + 1u));
    }
    assert_int_equal(aacmm_device_counters(&D)->samples_sent, 5001u);
    assert_int_equal(aacmm_device_counters(&D)->samples_dropped, 0u);
}

static void test_stream_odd_rate_and_jitter(void **state)
{
    /* 7 Hz with irregular wake-ups: sample k is due at t0 + floor(k * 1e6 / 7),
     * each comes exactly once, none early. */
    static const uint32_t steps[] = {1, 50000, 92856, 142857, 3, 250000, 1, 1, 7000, 400000};
    uint64_t t0;
    uint32_t got = 0;
    size_t i;
    int round;
    (void)state;
    t0 = F.now_us;
    start_stream(7, 0);
    for (round = 0; round < 30; round++) {
        for (i = 0; i < sizeof steps / sizeof steps[0]; i++) {
            uint64_t elapsed;
            advance(steps[i]);
            aacmm_device_poll(&D);
            while (next_msg()) {
                assert_int_equal(M.u.sample.seq, got);
                assert_true(M.u.sample.timestamp_us >= t0 + ((uint64_t)got * 1000000u) / 7u);
                got++;
            }
            elapsed = F.now_us - t0;
            /* samples due so far: k with floor(k * 1e6 / 7) <= elapsed */
            {
                uint64_t due = 0;
                while ((due * 1000000u) / 7u <= elapsed) {
                    due++;
                }
                assert_int_equal(got, (uint32_t)due);
            }
        }
    }
}

static void test_stream_catch_up_and_stall(void **state)
{
    uint32_t seq = 0;
    int overrun_seen = 0;
    (void)state;
    start_stream(1000, 0);
    while (next_msg()) {
        seq++;
    }
    /* A 20 ms hiccup: the 20 missed samples are sent at once, numbered. */
    advance(20000u);
    aacmm_device_poll(&D);
    while (next_msg()) {
        assert_int_equal(M.u.sample.seq, seq);
        seq++;
    }
    assert_int_equal(seq, 21u);
    /* A 1 s stall: too late to catch up: one sample, with the gap visible. */
    advance(1000000u);
    aacmm_device_poll(&D);
    while (next_msg()) {
        assert_int_equal(M.u.sample.seq, 1020u);
        overrun_seen = (M.u.sample.status & AACMM_SAMPLE_OVERRUN) != 0u;
        seq++;
    }
    assert_int_equal(seq, 22u);
    assert_true(overrun_seen);
    assert_int_equal(aacmm_device_counters(&D)->samples_late, 999u);
    advance(1000u);
    aacmm_device_poll(&D);
    assert_true(next_msg());
    assert_int_equal(M.u.sample.seq, 1021u);
    assert_int_equal(M.u.sample.status & AACMM_SAMPLE_OVERRUN, 0u);
}

static void test_stream_output_full(void **state)
{
    uint32_t last = 0;
    uint32_t n = 0;
    int overrun = 0;
    aacmm_msg_t m;
    (void)state;
    start_stream(1000, AACMM_CONTENT_JACOBIAN);
    F.tx_limit = 0; /* the host stops reading */
    {
        int k;
        for (k = 0; k < 1000; k++) {
            advance(1000u);
            aacmm_device_poll(&D);
        }
    }
    /* A request arrives while the queue is full of samples: it is answered
     * as soon as there is room (never dropped). */
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_PING_REQ;
    m.seq = 123;
    m.u.ping.token = 5;
    send_msg(&m);
    advance(1000u);
    aacmm_device_poll(&D);
    assert_true(aacmm_device_counters(&D)->samples_dropped > 800u);
    assert_true(aacmm_device_serial_pending(&D) > 0u);
    F.tx_limit = (size_t)-1;
    advance(1000u);
    aacmm_device_poll(&D);
    {
        int got_ping = 0;
        while (next_msg()) {
            if (M.type == AACMM_MSG_PING_RSP) {
                assert_int_equal(M.seq, 123);
                got_ping = 1;
                continue;
            }
            assert_int_equal(M.type, AACMM_MSG_SAMPLE_EVT);
            if (n > 0 && M.u.sample.seq != last + 1u) {
                /* the first sample after a gap says so */
                assert_true((M.u.sample.status & AACMM_SAMPLE_OVERRUN) != 0u);
                overrun = 1;
            }
            last = M.u.sample.seq;
            n++;
        }
        assert_true(got_ping);
    }
    assert_true(overrun);
    assert_int_equal(last, 1002u);
    assert_int_equal(n + aacmm_device_counters(&D)->samples_dropped, 1003u);
}

/* #15.8: after the host stalled, a request is answered behind at most the
 * frame in progress, not behind the queued samples. */
static void test_response_not_behind_queued_samples(void **state)
{
    aacmm_msg_t m;
    size_t mark;
    size_t before_rsp = 0u;
    int found = 0;
    int k;
    (void)state;
    start_stream(1000, AACMM_CONTENT_JACOBIAN);
    while (next_msg()) {
    }
    F.tx_limit = 0; /* the host stalls for 1 s */
    for (k = 0; k < 1000; k++) {
        advance(1000u);
        aacmm_device_poll(&D);
    }
    assert_true(aacmm_device_serial_pending(&D) > 32u * 1024u); /* a full queue waits */
    mark = F.tx_len;
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_PING_REQ;
    m.seq = 77;
    m.u.ping.token = 0xABCDu;
    send_msg(&m);
    F.tx_limit = 600u; /* the host reads again, a frame or so per write */
    for (k = 0; k < 3 && !found; k++) {
        advance(1000u);
        aacmm_device_poll(&D);
        while (next_msg()) {
            if (M.type == AACMM_MSG_PING_RSP) {
                assert_int_equal(M.seq, 77);
                found = 1;
                break;
            }
            if (host_pos > mark) {
                before_rsp = host_pos - mark;
            }
        }
    }
    assert_true(found);
    /* only the frame that was in progress went out before the answer */
    assert_true(before_rsp <= AACMM_FRAME_MAX_WIRE);
    assert_int_equal(host_rx.stats.crc_errors + host_rx.stats.cobs_errors, 0u);
}

/* #15.8: samples that waited longer than max_sample_age in the queue are
 * dropped (counted), the first sample after them carries OVERRUN, and
 * nothing older than the bound reaches the host. */
static void test_stale_samples_dropped(void **state)
{
    uint32_t last = 0;
    uint32_t n = 0;
    int overrun_after_gap = 0;
    const aacmm_device_counters_t *c;
    int k;
    (void)state;
    CFG.max_sample_age_ms = 100u;
    boot();
    start_stream(1000, AACMM_CONTENT_JACOBIAN);
    assert_true(next_msg()); /* sample 0, sent before the stall */
    assert_int_equal(M.u.sample.seq, 0u);
    n = 1u;
    F.tx_limit = 0;
    for (k = 0; k < 500; k++) {
        advance(1000u);
        aacmm_device_poll(&D);
    }
    F.tx_limit = (size_t)-1;
    advance(1000u);
    aacmm_device_poll(&D);
    while (next_msg()) {
        assert_int_equal(M.type, AACMM_MSG_SAMPLE_EVT);
        /* nothing that waited longer than 100 ms (plus this poll's 1 ms) */
        assert_true(F.now_us - M.u.sample.timestamp_us <= 101000u);
        if (n > 0 && M.u.sample.seq != last + 1u) {
            assert_true((M.u.sample.status & AACMM_SAMPLE_OVERRUN) != 0u);
            overrun_after_gap = 1;
        }
        last = M.u.sample.seq;
        n++;
    }
    c = aacmm_device_counters(&D);
    assert_true(overrun_after_gap || n == 1u);
    assert_true(c->samples_stale > 0u);
    assert_int_equal(last, 501u);
    assert_int_equal(n + c->samples_dropped, 502u);
    assert_int_equal(host_rx.stats.crc_errors + host_rx.stats.cobs_errors, 0u);
}

/* ------------------------------------------------------------------------ */
/* storage                                                                   */
/* ------------------------------------------------------------------------ */

static void save_via_request(uint8_t seq)
{
    send_simple(AACMM_MSG_SAVE_PARAMS_REQ, seq);
    aacmm_device_poll(&D);
    assert_true(next_msg());
    assert_int_equal(M.seq, seq);
}

static void test_save_and_reload(void **state)
{
    aacmm_param_set_t s;
    (void)state;
    other_set(&s, 200.0);
    set_params(&s, 1);
    save_via_request(2);
    assert_int_equal(M.type, AACMM_MSG_SAVE_PARAMS_RSP);
    assert_int_equal(M.u.param_crc.param_crc32, set_crc(&s));
    /* Reboot on the same storage. */
    setup_links(1, 1, 1, 1, 1);
    boot();
    send_simple(AACMM_MSG_INFO_REQ, 3);
    expect_response(AACMM_MSG_INFO_RSP, 3);
    assert_int_equal(M.u.info.param_source, AACMM_PARAM_SOURCE_STORAGE);
    assert_int_equal(M.u.info.storage_state, AACMM_STORAGE_OK);
    assert_int_equal(M.u.info.param_crc32, set_crc(&s));
    /* Samples no longer carry PARAMS_DEFAULT. */
    send_simple(AACMM_MSG_MEASURE_REQ, 4);
    expect_response(AACMM_MSG_MEASURE_RSP, 4);
    assert_int_equal(M.u.sample.status & AACMM_SAMPLE_PARAMS_DEFAULT, 0u);
}

static void test_store_alternates_slots(void **state)
{
    aacmm_param_set_t s;
    aacmm_param_set_t got;
    uint8_t rec[AACMM_STORE_RECORD_BYTES];
    aacmm_store_report_t rep;
    uint8_t st = 0;
    int i;
    (void)state;
    setup_links(1, 0, 1, 0, 0);
    fake_platform(&F, &PF, 1, 0, 1, 0);
    assert_int_equal(aacmm_store_load(&PF, &got, &st, NULL, NULL, rec), AACMM_ERR_STORAGE);
    assert_int_equal(st, AACMM_STORAGE_EMPTY);
    for (i = 0; i < 5; i++) {
        uint8_t slot = (uint8_t)(i % 2);
        other_set(&s, 100.0 + i);
        assert_int_equal(aacmm_store_save(&PF, &s, &rep, rec), AACMM_OK);
        assert_int_equal(rep.slot_generation[slot], (uint32_t)i + 1u);
        assert_int_equal(rep.newest, slot);
        assert_int_equal(rep.slot_state[slot], AACMM_SLOT_NEWEST);
        assert_int_equal(rep.slot_state[1 - slot], i == 0 ? AACMM_SLOT_ERASED : AACMM_SLOT_OLDER);
        memset(&rep, 0x5A, sizeof rep);
        assert_int_equal(aacmm_store_load(&PF, &got, &st, &rep, NULL, rec), AACMM_OK);
        assert_int_equal(st, AACMM_STORAGE_OK);
        assert_int_equal(rep.newest, slot);
        assert_int_equal(rep.slot_state[slot], AACMM_SLOT_NEWEST);
        assert_int_equal(rep.slot_state[1 - slot], i == 0 ? AACMM_SLOT_ERASED : AACMM_SLOT_OLDER);
        assert_int_equal(set_crc(&got), set_crc(&s));
    }
}

/* The bytes a save writes for a set of the paper's shape (other_set). */
#define PAPER_RECORD_LEN ((long)AACMM_STORE_RECORD_LEN(AACMM_PARAM_SET_PAPER_BYTES))

/* The heart of it: cut the power after every byte of a save. The device
 * always comes back with either the previous good set or the new one. */
static void test_power_cut_at_every_byte(void **state)
{
    aacmm_param_set_t old_set;
    aacmm_param_set_t new_set;
    uint8_t rec[AACMM_STORE_RECORD_BYTES];
    uint8_t before[AACMM_STORE_BYTES];
    long cut;
    int pass;
    (void)state;
    /* pass 0: one old record; pass 1: two old records (the older one is overwritten). */
    for (pass = 0; pass < 2; pass++) {
        setup_links(1, 0, 1, 0, 0);
        other_set(&old_set, 111.0);
        if (pass == 1) {
            aacmm_param_set_t older;
            other_set(&older, 99.0);
            assert_int_equal(aacmm_store_save(&PF, &older, NULL, rec), AACMM_OK);
        }
        assert_int_equal(aacmm_store_save(&PF, &old_set, NULL, rec), AACMM_OK);
        memcpy(before, F.storage, sizeof before);
        other_set(&new_set, 222.0);
        for (cut = 0; cut <= PAPER_RECORD_LEN; cut++) {
            aacmm_status_t st;
            memcpy(F.storage, before, sizeof before);
            F.write_budget = cut;
            st = aacmm_store_save(&PF, &new_set, NULL, rec);
            F.write_budget = -1;
            if (cut < PAPER_RECORD_LEN) {
                assert_int_not_equal(st, AACMM_OK);
            } else {
                assert_int_equal(st, AACMM_OK);
            }
            /* Power back on: boot the device on this storage. */
            setup_links(1, 0, 1, 0, 1);
            boot();
            assert_int_equal(D.storage_state, AACMM_STORAGE_OK);
            assert_int_equal(D.param_source, AACMM_PARAM_SOURCE_STORAGE);
            if (cut < PAPER_RECORD_LEN) {
                assert_int_equal(D.active_crc32, set_crc(&old_set));
            } else {
                assert_int_equal(D.active_crc32, set_crc(&new_set));
            }
        }
    }
}

/* Through the device: a cut during SAVE_PARAMS answers an error and the
 * previous set is still there after a reboot. */
static void test_power_cut_via_request(void **state)
{
    aacmm_param_set_t a;
    aacmm_param_set_t b;
    (void)state;
    other_set(&a, 120.0);
    other_set(&b, 130.0);
    set_params(&a, 1);
    save_via_request(2);
    assert_int_equal(M.type, AACMM_MSG_SAVE_PARAMS_RSP);
    set_params(&b, 3);
    F.write_budget = 100;
    save_via_request(4);
    assert_int_equal(M.type, AACMM_MSG_ERROR_RSP);
    assert_int_equal(M.u.error.status, AACMM_ERR_STORAGE);
    assert_int_equal(aacmm_device_counters(&D)->storage_errors, 1u);
    setup_links(1, 0, 1, 0, 1);
    boot();
    assert_int_equal(D.active_crc32, set_crc(&a));
    assert_int_equal(D.counters.storage_bad_records, 1u); /* the torn slot */
}

/* A record written by hand as docs (aacmm/device.h) lay it out: magic,
 * version, payload length, generation, the set, CRC over all before it. */
static void write_raw_record(uint8_t slot, uint16_t version, uint32_t gen, const aacmm_param_set_t *s,
                             int corrupt)
{
    uint8_t *r = F.storage + (size_t)slot * AACMM_STORE_SLOT_BYTES;
    uint32_t crc;
    size_t len = 0u;
    assert_int_equal(aacmm_param_set_encode(s, r + 12, AACMM_PARAM_SET_MAX_BYTES, &len), AACMM_OK);
    r[0] = 0x41;
    r[1] = 0x41;
    r[2] = 0x43;
    r[3] = 0x4D;
    r[4] = (uint8_t)version;
    r[5] = (uint8_t)(version >> 8);
    r[6] = (uint8_t)(len & 0xFFu);
    r[7] = (uint8_t)(len >> 8);
    r[8] = (uint8_t)gen;
    r[9] = (uint8_t)(gen >> 8);
    r[10] = (uint8_t)(gen >> 16);
    r[11] = (uint8_t)(gen >> 24);
    crc = aacmm_crc32(r, 12u + len);
    r[12u + len] = (uint8_t)crc;
    r[13u + len] = (uint8_t)(crc >> 8);
    r[14u + len] = (uint8_t)(crc >> 16);
    r[15u + len] = (uint8_t)(crc >> 24);
    if (corrupt) {
        r[100] ^= 0x01;
    }
}

static void test_store_generation_wraps(void **state)
{
    aacmm_param_set_t s;
    aacmm_param_set_t got;
    uint8_t rec[AACMM_STORE_RECORD_BYTES];
    aacmm_store_report_t rep;
    uint8_t st = 0;
    (void)state;
    setup_links(1, 0, 1, 0, 0);
    other_set(&s, 100.0);
    write_raw_record(0, AACMM_STORE_VERSION, 0xFFFFFFFFu, &s, 0);
    write_raw_record(1, AACMM_STORE_VERSION, 0xFFFFFFFEu, &s, 0);
    assert_int_equal(aacmm_store_load(&PF, &got, &st, &rep, NULL, rec), AACMM_OK);
    assert_int_equal(rep.newest, 0u);
    assert_int_equal(rep.slot_generation[0], 0xFFFFFFFFu);
    other_set(&s, 333.0);
    assert_int_equal(aacmm_store_save(&PF, &s, &rep, rec), AACMM_OK);
    assert_int_equal(rep.slot_generation[1], 0u);
    assert_int_equal(rep.newest, 1u);
    assert_int_equal(aacmm_store_load(&PF, &got, &st, &rep, NULL, rec), AACMM_OK);
    assert_int_equal(rep.newest, 1u); /* 0 is newer than 0xFFFFFFFF */
    assert_true(got.arm.tip_mm[2] > 332.9 && got.arm.tip_mm[2] < 333.1);
    other_set(&s, 444.0);
    assert_int_equal(aacmm_store_save(&PF, &s, &rep, rec), AACMM_OK);
    assert_int_equal(rep.slot_generation[0], 1u);
    assert_int_equal(rep.newest, 0u);
}

static uint8_t info_source(uint8_t seq)
{
    send_simple(AACMM_MSG_INFO_REQ, seq);
    expect_response(AACMM_MSG_INFO_RSP, seq);
    return M.u.info.param_source;
}

static void diag(uint8_t seq)
{
    send_simple(AACMM_MSG_DIAG_REQ, seq);
    expect_response(AACMM_MSG_DIAG_RSP, seq);
}

/* #14.1: the three parameter states, through every transition. */
static void test_param_source_three_states(void **state)
{
    aacmm_param_set_t a;
    aacmm_param_set_t b;
    (void)state;
    other_set(&a, 120.0);
    other_set(&b, 130.0);
    setup_links(1, 0, 1, 0, 0);
    boot();
    assert_int_equal(info_source(1), AACMM_PARAM_SOURCE_DEFAULTS);
    set_params(&a, 2);
    assert_int_equal(info_source(3), AACMM_PARAM_SOURCE_HOST);
    send_simple(AACMM_MSG_MEASURE_REQ, 4); /* not defaults: no PARAMS_DEFAULT */
    expect_response(AACMM_MSG_MEASURE_RSP, 4);
    assert_int_equal(M.u.sample.status & AACMM_SAMPLE_PARAMS_DEFAULT, 0u);
    save_via_request(5);
    assert_int_equal(M.type, AACMM_MSG_SAVE_PARAMS_RSP);
    assert_int_equal(info_source(6), AACMM_PARAM_SOURCE_STORAGE);
    set_params(&b, 7);
    assert_int_equal(info_source(8), AACMM_PARAM_SOURCE_HOST);
    set_params(&a, 9); /* exactly the stored set again */
    assert_int_equal(info_source(10), AACMM_PARAM_SOURCE_STORAGE);
    set_params(&b, 11);
    send_simple(AACMM_MSG_RESTORE_DEFAULTS_REQ, 12);
    expect_response(AACMM_MSG_RESTORE_DEFAULTS_RSP, 12);
    assert_int_equal(info_source(13), AACMM_PARAM_SOURCE_DEFAULTS);
    /* A restart loads the saved set a, not b and not the defaults. */
    setup_links(1, 0, 1, 0, 1);
    boot();
    assert_int_equal(info_source(14), AACMM_PARAM_SOURCE_STORAGE);
    assert_int_equal(M.u.info.param_crc32, set_crc(&a));
    /* Without storage a set stays "not saved". */
    setup_links(1, 0, 0, 0, 0);
    boot();
    set_params(&a, 15);
    assert_int_equal(info_source(16), AACMM_PARAM_SOURCE_HOST);
}

/* DIAG_RSP: storage kind, slots, reset facts from the config, uptime. */
static void test_diag_request(void **state)
{
    aacmm_param_set_t a;
    (void)state;
    other_set(&a, 120.0);
    setup_links(1, 0, 1, 0, 0);
    PF.storage_kind = AACMM_STORAGE_KIND_FLASH;
    PF.storage_flags = AACMM_STORAGE_PERSISTENT | 0x80u; /* unknown bits are not reported */
    CFG.reset_cause = AACMM_RESET_WATCHDOG;
    CFG.reset_raw = 0x2u;
    CFG.boot_count = 4u;
    CFG.watchdog_ms = 1000u;
    boot();
    F.now_us += 2500u;
    diag(1);
    assert_int_equal(M.u.diag.storage_kind, AACMM_STORAGE_KIND_FLASH);
    assert_int_equal(M.u.diag.storage_flags, AACMM_STORAGE_PERSISTENT);
    assert_int_equal(M.u.diag.slot_state[0], AACMM_SLOT_ERASED);
    assert_int_equal(M.u.diag.slot_state[1], AACMM_SLOT_ERASED);
    assert_int_equal(M.u.diag.reset_cause, AACMM_RESET_WATCHDOG);
    assert_int_equal(M.u.diag.reset_raw, 2u);
    assert_int_equal(M.u.diag.boot_count, 4u);
    assert_int_equal(M.u.diag.watchdog_ms, 1000u);
    assert_int_equal(M.u.diag.uptime_us, 2500u);
    assert_int_equal(M.u.diag.joint[0].interface, AACMM_ENC_COUNTS);
    set_params(&a, 2);
    save_via_request(3);
    save_via_request(4);
    diag(5);
    assert_int_equal(M.u.diag.slot_state[0], AACMM_SLOT_OLDER);
    assert_int_equal(M.u.diag.slot_generation[0], 1u);
    assert_int_equal(M.u.diag.slot_state[1], AACMM_SLOT_NEWEST);
    assert_int_equal(M.u.diag.slot_generation[1], 2u);
    /* No storage at all: kind NONE, whatever the table says. */
    setup_links(1, 0, 0, 0, 0);
    PF.storage_kind = AACMM_STORAGE_KIND_FILE;
    boot();
    diag(6);
    assert_int_equal(M.u.diag.storage_kind, AACMM_STORAGE_KIND_NONE);
    assert_int_equal(M.u.diag.storage_flags, 0u);
    /* A torn frame on the line, a joint out of range and a failed read are
     * counted. */
    F.rx[F.rx_len++] = 0x00;
    F.rx[F.rx_len++] = 0x05;
    F.rx[F.rx_len++] = 0x01;
    F.rx[F.rx_len++] = 0x00;
    aacmm_device_poll(&D);
    {
        aacmm_param_set_t small;
        default_set(&small);
        small.enc.counts_per_rev[2] = 1000u;
        set_params(&small, 7);
    }
    F.counts[2] = 1000u;
    send_simple(AACMM_MSG_MEASURE_REQ, 8);
    expect_response(AACMM_MSG_MEASURE_RSP, 8);
    assert_int_equal(M.u.sample.status & (AACMM_SAMPLE_POINT_VALID | AACMM_SAMPLE_ENCODER_FAULT),
                     AACMM_SAMPLE_ENCODER_FAULT);
    assert_int_equal(M.u.sample.status & AACMM_SAMPLE_JOINT_FAULTS, AACMM_SAMPLE_JOINT3_FAULT);
    assert_int_equal(M.u.sample.counts[2], 1000u); /* the raw reading is kept */
    F.encoder_status = AACMM_ERR_IO;
    send_simple(AACMM_MSG_MEASURE_REQ, 9);
    expect_response(AACMM_MSG_MEASURE_RSP, 9);
    assert_int_equal(M.u.sample.status & AACMM_SAMPLE_JOINT_FAULTS, 0x3F00u); /* joints 1..6 */
    diag(10);
    assert_int_equal(M.u.diag.serial_frames_bad, 1u);
    assert_int_equal(M.u.diag.encoder_faults, 2u);
    assert_int_equal(M.u.diag.joint[2].faults, 2u);
    assert_int_equal(M.u.diag.joint[2].last_fault, AACMM_ENC_FAULT_READ);
    assert_int_equal(M.u.diag.joint[0].faults, 1u);
    assert_int_equal(M.u.diag.joint[0].last_fault, AACMM_ENC_FAULT_READ);
}

static void boot_on_storage_and_check(uint8_t state, uint8_t source, uint32_t bad)
{
    setup_links(1, 0, 1, 0, 1);
    boot();
    send_simple(AACMM_MSG_INFO_REQ, 5);
    expect_response(AACMM_MSG_INFO_RSP, 5);
    assert_int_equal(M.u.info.storage_state, state);
    assert_int_equal(M.u.info.param_source, source);
    assert_int_equal(D.counters.storage_bad_records, bad);
}

static void test_corrupt_and_foreign_records(void **state)
{
    aacmm_param_set_t s;
    aacmm_param_set_t def;
    (void)state;
    other_set(&s, 144.0);
    default_set(&def);
    /* Empty (erased). */
    setup_links(1, 0, 1, 0, 0);
    boot_on_storage_and_check(AACMM_STORAGE_EMPTY, AACMM_PARAM_SOURCE_DEFAULTS, 0);
    /* Zeroed storage is empty too. */
    memset(F.storage, 0, sizeof F.storage);
    boot_on_storage_and_check(AACMM_STORAGE_EMPTY, AACMM_PARAM_SOURCE_DEFAULTS, 0);
    /* One record with a flipped bit. */
    memset(F.storage, 0xFF, sizeof F.storage);
    write_raw_record(0, AACMM_STORE_VERSION, 1, &s, 1);
    boot_on_storage_and_check(AACMM_STORAGE_CORRUPT, AACMM_PARAM_SOURCE_DEFAULTS, 1);
    assert_int_equal(M.u.info.param_crc32, set_crc(&def));
    send_simple(AACMM_MSG_MEASURE_REQ, 6);
    expect_response(AACMM_MSG_MEASURE_RSP, 6);
    assert_true((M.u.sample.status & AACMM_SAMPLE_PARAMS_DEFAULT) != 0u);
    /* A record of a future format. */
    memset(F.storage, 0xFF, sizeof F.storage);
    write_raw_record(1, 3, 1, &s, 0);
    boot_on_storage_and_check(AACMM_STORAGE_VERSION, AACMM_PARAM_SOURCE_DEFAULTS, 1);
    /* A record of format 1 (the six-joint set before arm models): another
     * version, not used; the device says so. */
    memset(F.storage, 0xFF, sizeof F.storage);
    write_raw_record(0, 1, 5, &s, 0);
    boot_on_storage_and_check(AACMM_STORAGE_VERSION, AACMM_PARAM_SOURCE_DEFAULTS, 1);
    assert_int_equal(D.store.slot_state[0], AACMM_SLOT_VERSION);
    /* A good record beside a corrupt newer one: the good one wins. */
    memset(F.storage, 0xFF, sizeof F.storage);
    write_raw_record(0, AACMM_STORE_VERSION, 7, &s, 0);
    write_raw_record(1, AACMM_STORE_VERSION, 8, &def, 1);
    boot_on_storage_and_check(AACMM_STORAGE_OK, AACMM_PARAM_SOURCE_STORAGE, 1);
    assert_int_equal(M.u.info.param_crc32, set_crc(&s));
    /* Newest of two valid records wins. */
    write_raw_record(1, AACMM_STORE_VERSION, 8, &def, 0);
    boot_on_storage_and_check(AACMM_STORAGE_OK, AACMM_PARAM_SOURCE_STORAGE, 0);
    assert_int_equal(M.u.info.param_crc32, set_crc(&def));
    /* A record with a good CRC but parameters out of range is corrupt. */
    memset(F.storage, 0xFF, sizeof F.storage);
    s.arm.a_mm[0] = 50000.0;
    write_raw_record(0, AACMM_STORE_VERSION, 1, &s, 0);
    boot_on_storage_and_check(AACMM_STORAGE_CORRUPT, AACMM_PARAM_SOURCE_DEFAULTS, 1);
    /* Read errors: defaults, counted. */
    setup_links(1, 0, 1, 0, 1);
    F.read_error = 1;
    boot();
    assert_int_equal(D.param_source, AACMM_PARAM_SOURCE_DEFAULTS);
    assert_int_equal(D.counters.storage_errors, 1u);
    assert_int_equal(D.store.slot_state[0], AACMM_SLOT_READ_ERROR);
    assert_int_equal(D.store.slot_state[1], AACMM_SLOT_READ_ERROR);
}

/* #15.7: the slots say what was found, and a damaged newest record that
 * leaves the older set active is reported, not hidden. */
static void test_store_report_says_what_was_found(void **state)
{
    aacmm_param_set_t older;
    aacmm_param_set_t newer;
    uint32_t x = 12345u;
    size_t i;
    (void)state;
    other_set(&older, 144.0);
    other_set(&newer, 155.0);
    /* Newest record damaged: the older one is loaded, the report says which
     * slot and why the other was rejected; the bad record is counted. */
    setup_links(1, 0, 1, 0, 0);
    write_raw_record(0, AACMM_STORE_VERSION, 7, &older, 0);
    write_raw_record(1, AACMM_STORE_VERSION, 8, &newer, 1);
    boot_on_storage_and_check(AACMM_STORAGE_OK, AACMM_PARAM_SOURCE_STORAGE, 1);
    diag(6);
    assert_int_equal(M.u.diag.slot_state[0], AACMM_SLOT_NEWEST);
    assert_int_equal(M.u.diag.slot_generation[0], 7u);
    assert_int_equal(M.u.diag.slot_state[1], AACMM_SLOT_BAD_CRC);
    assert_int_equal(M.u.diag.slot_generation[1], 8u); /* newer than the set in use */
    assert_int_equal(M.u.diag.storage_bad_records, 1u);
    /* The magic overwritten: "unrecognised data", counted (it was silently
     * "empty" before). */
    F.storage[AACMM_STORE_SLOT_BYTES] = 0x00;
    boot_on_storage_and_check(AACMM_STORAGE_OK, AACMM_PARAM_SOURCE_STORAGE, 1);
    assert_int_equal(D.store.slot_state[1], AACMM_SLOT_UNRECOGNISED);
    /* Random bytes everywhere: not "no record" but unrecognised data. */
    for (i = 0; i < sizeof F.storage; i++) {
        x = x * 1103515245u + 12345u;
        F.storage[i] = (uint8_t)(x >> 16);
    }
    boot_on_storage_and_check(AACMM_STORAGE_CORRUPT, AACMM_PARAM_SOURCE_DEFAULTS, 2);
    assert_int_equal(D.store.slot_state[0], AACMM_SLOT_UNRECOGNISED);
    assert_int_equal(D.store.slot_state[1], AACMM_SLOT_UNRECOGNISED);
    /* Only the 4-byte magic (a 4-byte file; flash cut after the first word):
     * an incomplete record, not "another version". */
    memset(F.storage, 0xFF, sizeof F.storage);
    memcpy(F.storage, "AACM", 4);
    boot_on_storage_and_check(AACMM_STORAGE_CORRUPT, AACMM_PARAM_SOURCE_DEFAULTS, 1);
    assert_int_equal(D.store.slot_state[0], AACMM_SLOT_INCOMPLETE);
    assert_int_equal(D.store.slot_state[1], AACMM_SLOT_ERASED);
    /* Wrong length field, and another version. */
    memset(F.storage, 0xFF, sizeof F.storage);
    write_raw_record(0, AACMM_STORE_VERSION, 3, &older, 0);
    F.storage[6] = 0x10;
    write_raw_record(1, 9, 4, &older, 0);
    boot_on_storage_and_check(AACMM_STORAGE_CORRUPT, AACMM_PARAM_SOURCE_DEFAULTS, 2);
    assert_int_equal(D.store.slot_state[0], AACMM_SLOT_BAD_LENGTH);
    assert_int_equal(D.store.slot_state[1], AACMM_SLOT_VERSION);
}

/* ------------------------------------------------------------------------ */
/* button                                                                    */
/* ------------------------------------------------------------------------ */

static void test_button_events(void **state)
{
    size_t can_before;
    (void)state;
    F.counts[0] = 0x01000000u;
    aacmm_device_poll(&D);
    assert_false(next_msg());
    F.button = 1;
    advance(1000u);
    can_before = F.can_tx_len;
    aacmm_device_poll(&D);
    assert_true(next_msg());
    assert_int_equal(M.type, AACMM_MSG_TRIGGER_EVT);
    assert_int_equal(M.u.trigger.button, 0);
    assert_int_equal(M.u.trigger.pressed, 1);
    assert_int_equal(M.u.trigger.sample.counts[0], 0x01000000u);
    assert_int_equal(M.u.trigger.sample.timestamp_us, F.now_us);
    assert_true((M.u.trigger.sample.status & AACMM_SAMPLE_TRIGGER_DOWN) != 0u);
    assert_true((M.u.trigger.sample.status & AACMM_SAMPLE_POINT_VALID) != 0u);
    assert_true((M.u.trigger.sample.status & AACMM_SAMPLE_TRIGGER_EVENT) != 0u);
    assert_int_equal(M.u.trigger.sample.seq, 0u); /* no stream yet: its next seq is 0 */
    assert_false(next_msg());
    /* CAN: the sample as six sample frames (seq 0), then the trigger frame. */
    assert_int_equal(F.can_tx_len, can_before + 7u);
    assert_int_equal(F.can_tx[can_before].id, AACMM_CAN_ID_SAMPLE_HEADER + 3u);
    assert_int_equal(F.can_tx[can_before].data[0], 0);
    assert_int_equal(F.can_tx[can_before + 1u].data[3], 0x01); /* count 1, high byte */
    assert_int_equal(F.can_tx[can_before + 5u].id, AACMM_CAN_ID_POINT_Z + 3u);
    assert_int_equal(F.can_tx[can_before + 6u].id, AACMM_CAN_ID_TRIGGER + 3u);
    assert_int_equal(F.can_tx[can_before + 6u].data[0], 0); /* seq */
    assert_int_equal(F.can_tx[can_before + 6u].data[4], 0); /* button */
    assert_int_equal(F.can_tx[can_before + 6u].data[5], 1); /* pressed */
    assert_int_equal(F.can_tx[can_before + 5u].data[4] & AACMM_SAMPLE_TRIGGER_EVENT,
                     AACMM_SAMPLE_TRIGGER_EVENT); /* Status, low byte */
    /* Held: no more events. */
    advance(1000u);
    aacmm_device_poll(&D);
    assert_false(next_msg());
    F.button = 0;
    advance(1000u);
    aacmm_device_poll(&D);
    assert_true(next_msg());
    assert_int_equal(M.type, AACMM_MSG_TRIGGER_EVT);
    assert_int_equal(M.u.trigger.pressed, 0);
    assert_int_equal(M.u.trigger.sample.status & AACMM_SAMPLE_TRIGGER_DOWN, 0u);
    assert_int_equal(F.can_tx[F.can_tx_len - 1u].id, AACMM_CAN_ID_TRIGGER + 3u);
    assert_int_equal(F.can_tx[F.can_tx_len - 1u].data[0], 0); /* still no stream sample */
    assert_int_equal(F.can_tx[F.can_tx_len - 1u].data[5], 0);
    assert_int_equal(aacmm_device_counters(&D)->button_edges, 2u);
}

static void test_button_during_stream(void **state)
{
    uint32_t last_seq = 0;
    int k;
    (void)state;
    start_stream(1000, AACMM_CONTENT_JACOBIAN);
    for (k = 0; k < 10; k++) {
        advance(1000u);
        aacmm_device_poll(&D);
    }
    while (next_msg()) {
        last_seq = M.u.sample.seq;
    }
    assert_int_equal(last_seq, 10u);
    advance(300u);
    F.button = 1;
    aacmm_device_poll(&D);
    assert_true(next_msg());
    assert_int_equal(M.type, AACMM_MSG_TRIGGER_EVT);
    assert_int_equal(M.u.trigger.sample.seq, 11u); /* the next stream sample's */
    assert_int_equal(M.u.trigger.sample.content, AACMM_CONTENT_JACOBIAN);
    assert_true((M.u.trigger.sample.status & AACMM_SAMPLE_TRIGGER_EVENT) != 0u);
    advance(700u);
    aacmm_device_poll(&D);
    assert_true(next_msg());
    assert_int_equal(M.type, AACMM_MSG_SAMPLE_EVT);
    assert_int_equal(M.u.sample.seq, 11u);
    assert_true((M.u.sample.status & AACMM_SAMPLE_TRIGGER_DOWN) != 0u);
    assert_int_equal(M.u.sample.status & AACMM_SAMPLE_TRIGGER_EVENT, 0u);
}

/* The second button (undo): its own index on both links, edges of both
 * buttons in one poll in button order, TRIGGER_DOWN only for button 0. */
static void test_two_buttons(void **state)
{
    size_t can_before;
    (void)state;
    F.button = 2u; /* undo pressed */
    advance(1000u);
    can_before = F.can_tx_len;
    aacmm_device_poll(&D);
    assert_true(next_msg());
    assert_int_equal(M.type, AACMM_MSG_TRIGGER_EVT);
    assert_int_equal(M.u.trigger.button, AACMM_BUTTON_UNDO);
    assert_int_equal(M.u.trigger.pressed, 1);
    assert_int_equal(M.u.trigger.sample.status & AACMM_SAMPLE_TRIGGER_DOWN, 0u);
    assert_false(next_msg());
    assert_int_equal(F.can_tx_len, can_before + 7u);
    assert_int_equal(F.can_tx[can_before + 6u].id, AACMM_CAN_ID_TRIGGER + 3u);
    assert_int_equal(F.can_tx[can_before + 6u].data[4], AACMM_BUTTON_UNDO);
    /* Both change at once: capture pressed, undo released, in button order. */
    F.button = 1u;
    advance(1000u);
    aacmm_device_poll(&D);
    assert_true(next_msg());
    assert_int_equal(M.u.trigger.button, AACMM_BUTTON_CAPTURE);
    assert_int_equal(M.u.trigger.pressed, 1);
    assert_true((M.u.trigger.sample.status & AACMM_SAMPLE_TRIGGER_DOWN) != 0u);
    assert_true(next_msg());
    assert_int_equal(M.u.trigger.button, AACMM_BUTTON_UNDO);
    assert_int_equal(M.u.trigger.pressed, 0);
    assert_false(next_msg());
    /* Bits beyond the buttons the device knows are ignored. */
    F.button = (uint8_t)(1u | 0xF0u);
    advance(1000u);
    aacmm_device_poll(&D);
    assert_false(next_msg());
    assert_int_equal(aacmm_device_counters(&D)->button_edges, 3u);
}

/* A button held at start-up is not an edge. */
static void test_button_held_at_boot(void **state)
{
    (void)state;
    setup_links(1, 0, 0, 1, 0);
    F.button = 3u;
    boot();
    aacmm_device_poll(&D);
    assert_false(next_msg());
    F.button = 1u;
    advance(1000u);
    aacmm_device_poll(&D);
    assert_true(next_msg());
    assert_int_equal(M.u.trigger.button, AACMM_BUTTON_UNDO);
    assert_int_equal(M.u.trigger.pressed, 0);
}

/* Stream info: starts count every STREAM_START (restarts too), next_seq is
 * the trigger's seq. */
static void test_stream_info(void **state)
{
    aacmm_device_stream_info_t si;
    int k;
    (void)state;
    assert_int_equal(aacmm_device_stream_info(NULL, AACMM_LINK_SERIAL, &si), AACMM_ERR_NULL);
    assert_int_equal(aacmm_device_stream_info(&D, 2u, &si), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_device_stream_info(&D, AACMM_LINK_SERIAL, &si), AACMM_OK);
    assert_int_equal(si.active, 0);
    assert_int_equal(si.starts, 0u);
    start_stream(200, 0);
    assert_int_equal(aacmm_device_stream_info(&D, AACMM_LINK_SERIAL, &si), AACMM_OK);
    assert_int_equal(si.active, 1);
    assert_int_equal(si.rate_hz, 200);
    assert_int_equal(si.starts, 1u);
    for (k = 0; k < 10; k++) {
        advance(5000u);
        aacmm_device_poll(&D);
    }
    assert_int_equal(aacmm_device_stream_info(&D, AACMM_LINK_SERIAL, &si), AACMM_OK);
    assert_int_equal(si.next_seq, 11u);
    while (next_msg()) {
    }
    start_stream(100, 0);
    assert_int_equal(aacmm_device_stream_info(&D, AACMM_LINK_SERIAL, &si), AACMM_OK);
    assert_int_equal(si.starts, 2u);
    assert_int_equal(aacmm_device_stream_info(&D, AACMM_LINK_CAN, &si), AACMM_OK);
    assert_int_equal(si.starts, 0u);
    assert_int_equal(si.active, 0);
}

/* ------------------------------------------------------------------------ */
/* CAN link                                                                  */
/* ------------------------------------------------------------------------ */

static aacmm_isotp_t host_tp;
static uint8_t host_tp_rx[AACMM_ISOTP_MAX_LEN];
static uint8_t host_tp_tx[AACMM_ISOTP_MAX_LEN];
static size_t can_seen;

static void host_isotp_init(uint8_t node)
{
    aacmm_isotp_config_t c;
    memset(&c, 0, sizeof c);
    c.tx_id = AACMM_CAN_ID_ISOTP_REQUEST + node;
    c.rx_id = AACMM_CAN_ID_ISOTP_RESPONSE + node;
    c.rx_buf = host_tp_rx;
    c.rx_cap = sizeof host_tp_rx;
    c.tx_buf = host_tp_tx;
    c.tx_cap = sizeof host_tp_tx;
    c.padding = 0xCC;
    c.max_wait = 10;
    c.timeout_ms = 1000;
    assert_int_equal(aacmm_isotp_init(&host_tp, &c), AACMM_OK);
    can_seen = F.can_tx_len;
}

/* Run host and device until the host has a complete ISO-TP message (into M)
 * or the rounds run out. Non-ISO-TP frames are left in F.can_tx. */
static int can_exchange(int rounds)
{
    int r;
    for (r = 0; r < rounds; r++) {
        aacmm_can_frame_t f;
        const uint8_t *data;
        size_t len;
        uint32_t ms = (uint32_t)(F.now_us / 1000u);
        while (aacmm_isotp_poll(&host_tp, ms, &f)) {
            assert_true(F.can_rx_len < FAKE_CAN_RX);
            F.can_rx[F.can_rx_len++] = f;
        }
        aacmm_device_poll(&D);
        while (can_seen < F.can_tx_len) {
            aacmm_isotp_on_frame(&host_tp, &F.can_tx[can_seen], ms);
            can_seen++;
            if (aacmm_isotp_receive(&host_tp, &data, &len)) {
                assert_int_equal(aacmm_msg_decode(data, len, &M), AACMM_OK);
                return 1;
            }
        }
        advance(100u);
    }
    return 0;
}

static void can_request(const aacmm_msg_t *m)
{
    uint8_t body[AACMM_PROTO_MAX_BODY];
    size_t n = 0;
    assert_int_equal(aacmm_msg_encode(m, body, sizeof body, &n), AACMM_OK);
    assert_int_equal(aacmm_isotp_send(&host_tp, body, n, (uint32_t)(F.now_us / 1000u)), AACMM_OK);
}

static void test_can_requests(void **state)
{
    aacmm_msg_t m;
    aacmm_param_set_t s;
    (void)state;
    host_isotp_init(3);
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_PING_REQ;
    m.seq = 1;
    m.u.ping.token = 0x11223344u;
    can_request(&m);
    assert_true(can_exchange(10));
    assert_int_equal(M.type, AACMM_MSG_PING_RSP);
    assert_int_equal(M.seq, 1);
    assert_int_equal(M.u.ping.token, 0x11223344u);
    /* A multi-frame request (flow control from the device) and a multi-frame
     * response (flow control from the host). */
    other_set(&s, 171.0);
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_SET_PARAMS_REQ;
    m.seq = 2;
    m.u.params = s;
    can_request(&m);
    assert_true(can_exchange(50));
    assert_int_equal(M.type, AACMM_MSG_SET_PARAMS_RSP);
    assert_int_equal(M.u.param_crc.param_crc32, set_crc(&s));
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_GET_PARAMS_REQ;
    m.seq = 3;
    can_request(&m);
    assert_true(can_exchange(50));
    assert_int_equal(M.type, AACMM_MSG_GET_PARAMS_RSP);
    assert_int_equal(set_crc(&M.u.params), set_crc(&s));
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_INFO_REQ;
    m.seq = 4;
    can_request(&m);
    assert_true(can_exchange(10));
    assert_int_equal(M.type, AACMM_MSG_INFO_RSP);
    assert_int_equal(M.u.info.can_node_id, 3);
    /* Errors come back over ISO-TP as well. */
    {
        uint8_t body[3] = {AACMM_PROTO_VERSION, 0x3D, 5};
        assert_int_equal(aacmm_isotp_send(&host_tp, body, 3, (uint32_t)(F.now_us / 1000u)), AACMM_OK);
        assert_true(can_exchange(10));
        assert_int_equal(M.type, AACMM_MSG_ERROR_RSP);
        assert_int_equal(M.seq, 5);
        assert_int_equal(M.u.error.status, AACMM_ERR_UNKNOWN_TYPE);
    }
    /* Nothing went out on the serial link. */
    assert_false(next_msg());
    /* Frames for other nodes are ignored. */
    host_isotp_init(4);
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_PING_REQ;
    m.seq = 6;
    can_request(&m);
    assert_false(can_exchange(5));
}

static void test_can_stream_and_both_links(void **state)
{
    aacmm_msg_t m;
    size_t i;
    uint32_t can_samples = 0;
    uint32_t serial_samples = 0;
    int k;
    (void)state;
    host_isotp_init(3);
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_STREAM_START_REQ;
    m.seq = 7;
    m.u.stream.rate_hz = 500;
    m.u.stream.content = 0;
    can_request(&m);
    assert_true(can_exchange(5));
    assert_int_equal(M.type, AACMM_MSG_STREAM_START_RSP);
    assert_int_equal(M.u.stream.rate_hz, 500);
    assert_int_equal(M.u.stream.content, 0);
    start_stream(1000, 0); /* and a serial stream at the same time */
    for (k = 0; k < 100; k++) {
        advance(1000u);
        F.button = (uint8_t)(k >= 50 && k < 70); /* a press and a release on the way */
        aacmm_device_poll(&D);
    }
    while (next_msg()) {
        if (M.type == AACMM_MSG_TRIGGER_EVT) {
            continue;
        }
        assert_int_equal(M.u.sample.seq, serial_samples);
        serial_samples++;
    }
    assert_int_equal(serial_samples, 101u);
    /* CAN: groups of six frames in order; the stream's Seq counts up without
     * gaps, and the two trigger samples (status TRIGGER_EVENT) carry the
     * number of the stream sample that follows them. */
    for (i = 0; i < F.can_tx_len; i++) {
        const aacmm_can_frame_t *f = &F.can_tx[i];
        if (f->id == AACMM_CAN_ID_SAMPLE_HEADER + 3u) {
            uint32_t seq = (uint32_t)f->data[0] | ((uint32_t)f->data[1] << 8) |
                           ((uint32_t)f->data[2] << 16) | ((uint32_t)f->data[3] << 24);
            assert_true(i + 5u < F.can_tx_len);
            assert_int_equal(seq, can_samples);
            if ((F.can_tx[i + 5].data[4] & AACMM_SAMPLE_TRIGGER_EVENT) != 0u) {
                assert_int_equal(F.can_tx[i + 6].id, AACMM_CAN_ID_TRIGGER + 3u);
                continue; /* not a stream sample: the next one has the same seq */
            }
            assert_int_equal(F.can_tx[i + 1].id, AACMM_CAN_ID_COUNTS_12 + 3u);
            assert_int_equal(F.can_tx[i + 2].id, AACMM_CAN_ID_COUNTS_34 + 3u);
            assert_int_equal(F.can_tx[i + 3].id, AACMM_CAN_ID_COUNTS_56 + 3u);
            assert_int_equal(F.can_tx[i + 4].id, AACMM_CAN_ID_POINT_XY + 3u);
            assert_int_equal(F.can_tx[i + 5].id, AACMM_CAN_ID_POINT_Z + 3u);
            assert_int_equal(F.can_tx[i + 5].data[6], (uint8_t)seq);
            can_samples++;
        }
    }
    assert_int_equal(can_samples, 51u); /* 100 ms at 500 Hz, no numbers used by triggers */
    {
        int triggers = 0;
        for (i = 0; i < F.can_tx_len; i++) {
            if (F.can_tx[i].id == AACMM_CAN_ID_TRIGGER + 3u) {
                /* right after the six frames of the sample it names */
                assert_true(i >= 6u);
                assert_int_equal(F.can_tx[i - 6u].id, AACMM_CAN_ID_SAMPLE_HEADER + 3u);
                assert_memory_equal(F.can_tx[i].data, F.can_tx[i - 6u].data, 4);
                triggers++;
            }
        }
        assert_int_equal(triggers, 2);
    }
    /* Bus full: samples are dropped and counted, never block. */
    F.can_busy = 1;
    for (k = 0; k < 200; k++) {
        advance(1000u);
        aacmm_device_poll(&D);
    }
    assert_true(aacmm_device_counters(&D)->samples_dropped > 80u);
    assert_true(aacmm_device_can_pending(&D) <= AACMM_DEVICE_CAN_QUEUE);
    F.can_busy = 0;
    aacmm_device_poll(&D);
    assert_int_equal(aacmm_device_can_pending(&D), 0u);
}

static void test_can_jacobian_stream_over_isotp(void **state)
{
    aacmm_msg_t m;
    uint32_t n = 0;
    int rounds = 0;
    (void)state;
    host_isotp_init(3);
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_STREAM_START_REQ;
    m.seq = 8;
    m.u.stream.rate_hz = 1000;
    m.u.stream.content = AACMM_CONTENT_JACOBIAN;
    can_request(&m);
    assert_true(can_exchange(5));
    assert_int_equal(M.type, AACMM_MSG_STREAM_START_RSP);
    assert_int_equal(M.u.stream.rate_hz, AACMM_DEVICE_CAN_JAC_RATE_MAX_HZ);
    assert_int_equal(M.u.stream.content, AACMM_CONTENT_JACOBIAN);
    while (n < 20u && rounds < 1000) {
        if (can_exchange(200)) {
            assert_int_equal(M.type, AACMM_MSG_SAMPLE_EVT);
            assert_int_equal(M.u.sample.content, AACMM_CONTENT_JACOBIAN);
            assert_int_equal(M.u.sample.seq, n);
            assert_true((M.u.sample.status & AACMM_SAMPLE_POINT_VALID) != 0u);
            n++;
        }
        rounds++;
    }
    assert_int_equal(n, 20u);
    assert_int_equal(aacmm_device_counters(&D)->samples_dropped, 0u);
    /* No periodic sample frames for this stream. */
    {
        size_t i;
        for (i = 0; i < F.can_tx_len; i++) {
            assert_int_not_equal(F.can_tx[i].id, AACMM_CAN_ID_SAMPLE_HEADER + 3u);
        }
    }
}

static void test_encoder_io_fault(void **state)
{
    (void)state;
    F.encoder_status = AACMM_ERR_IO;
    start_stream(10, 0);
    assert_true(next_msg());
    assert_int_equal(M.type, AACMM_MSG_SAMPLE_EVT);
    assert_true((M.u.sample.status & AACMM_SAMPLE_ENCODER_FAULT) != 0u);
    assert_int_equal(M.u.sample.status & AACMM_SAMPLE_POINT_VALID, 0u);
    assert_int_equal(aacmm_device_counters(&D)->encoder_faults, 1u);
}

static void test_serial_io_errors_counted(void **state)
{
    (void)state;
    F.serial_error = 1;
    aacmm_device_poll(&D);
    aacmm_device_poll(&D);
    assert_true(aacmm_device_counters(&D)->serial_io_errors >= 2u);
    F.serial_error = 0;
    send_simple(AACMM_MSG_INFO_REQ, 1);
    expect_response(AACMM_MSG_INFO_RSP, 1);
}

/* ------------------------------------------------------------------------ */
/* simulated arm                                                             */
/* ------------------------------------------------------------------------ */

static void sim_cfg(aacmm_sim_config_t *c, aacmm_sim_motion_t motion, uint64_t cpr)
{
    memset(c, 0, sizeof *c);
    c->motion = motion;
    c->counts_per_rev = cpr;
    c->seed = 1;
}

static uint32_t count_dist(uint32_t a, uint32_t b, uint64_t cpr)
{
    uint64_t d = (a >= b) ? (uint64_t)(a - b) : (uint64_t)(b - a);
    return (uint32_t)(d > cpr / 2u ? cpr - d : d);
}

/* ------------------------------------------------------------------------ */
/* encoder frames: the simulated encoders' frames through the device decoder  */
/* ------------------------------------------------------------------------ */

static const uint8_t IFACES[3] = {AACMM_ENC_BISS_C, AACMM_ENC_SSI_BINARY, AACMM_ENC_SSI_GRAY};

/* Every interface, widths 1..32, many positions and Ack variants: the slave's
 * frame decodes to the position it was given. */
static void test_enc_frames_round_trip(void **state)
{
    uint32_t x = 99u;
    int t;
    unsigned bits;
    (void)state;
    for (t = 0; t < 3; t++) {
        for (bits = 1u; bits <= 32u; bits++) {
            aacmm_enc_joint_config_t c = {IFACES[t], (uint8_t)bits};
            uint32_t mask = bits == 32u ? 0xFFFFFFFFu : (1u << bits) - 1u;
            int k;
            for (k = 0; k < 40; k++) {
                aacmm_enc_frame_t f;
                uint32_t pos;
                uint32_t got = 12345u;
                uint8_t warn = 9u;
                x = x * 1664525u + 1013904223u;
                pos = (k == 0) ? 0u : (k == 1) ? mask : (x & mask);
                aacmm_sim_encoder_frame(&c, pos, AACMM_SIM_ENC_OK, x >> 7, &f);
                assert_int_equal(f.n_bits, aacmm_enc_clocks(&c));
                assert_int_equal(aacmm_enc_decode(&c, &f, &got, &warn), AACMM_ENC_FAULT_NONE);
                assert_int_equal(got, pos);
                assert_int_equal(warn, 0u);
            }
        }
    }
}

/* Every injected fault gives its fault, with position 0, for every Ack
 * variant; a warning keeps the position. */
static void test_enc_frames_faults(void **state)
{
    static const struct {
        uint8_t inject;
        uint8_t biss;
        uint8_t ssi;
    } cases[] = {
        {AACMM_SIM_ENC_BIT_FLIP, AACMM_ENC_FAULT_CRC, AACMM_ENC_FAULT_NONE},
        {AACMM_SIM_ENC_ERROR_BIT, AACMM_ENC_FAULT_ERROR_BIT, AACMM_ENC_FAULT_NONE},
        {AACMM_SIM_ENC_STUCK_LOW, AACMM_ENC_FAULT_STUCK_LOW, AACMM_ENC_FAULT_STUCK_LOW},
        {AACMM_SIM_ENC_STUCK_HIGH, AACMM_ENC_FAULT_STUCK_HIGH, AACMM_ENC_FAULT_STUCK_HIGH},
        {AACMM_SIM_ENC_NO_ANSWER, AACMM_ENC_FAULT_TIMEOUT, AACMM_ENC_FAULT_TIMEOUT},
        {AACMM_SIM_ENC_NO_START, AACMM_ENC_FAULT_TIMEOUT, AACMM_ENC_FAULT_NONE},
        {AACMM_SIM_ENC_FRAMING, AACMM_ENC_FAULT_NONE, AACMM_ENC_FAULT_FRAMING},
    };
    size_t i;
    uint32_t variant;
    int t;
    (void)state;
    for (t = 0; t < 3; t++) {
        aacmm_enc_joint_config_t c = {IFACES[t], 20u};
        for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
            uint8_t want = t == 0 ? cases[i].biss : cases[i].ssi;
            for (variant = 0u; variant < 400u; variant++) {
                aacmm_enc_frame_t f;
                uint32_t got = 7u;
                uint8_t warn = 7u;
                uint32_t pos = (variant * 2654435761u) & 0xFFFFFu;
                aacmm_sim_encoder_frame(&c, pos, cases[i].inject, variant, &f);
                assert_int_equal(aacmm_enc_decode(&c, &f, &got, &warn), want);
                assert_int_equal(got, want == AACMM_ENC_FAULT_NONE ? pos : 0u);
            }
        }
        /* a short frame is a fault (timeout, or a stuck line if what was
         * captured happens to be all ones) */
        for (variant = 0u; variant < 400u; variant++) {
            aacmm_enc_frame_t f;
            uint32_t got = 7u;
            uint8_t warn = 0u;
            uint8_t fault;
            aacmm_sim_encoder_frame(&c, variant * 977u & 0xFFFFFu, AACMM_SIM_ENC_SHORT, variant,
                                    &f);
            fault = aacmm_enc_decode(&c, &f, &got, &warn);
            assert_true(fault == AACMM_ENC_FAULT_TIMEOUT || fault == AACMM_ENC_FAULT_STUCK_HIGH);
            assert_int_equal(got, 0u);
        }
    }
    {
        aacmm_enc_joint_config_t c = {AACMM_ENC_BISS_C, 26u};
        aacmm_enc_frame_t f;
        uint32_t got = 0u;
        uint8_t warn = 0u;
        aacmm_sim_encoder_frame(&c, 0x2ABCDEFu, AACMM_SIM_ENC_WARNING, 5u, &f);
        assert_int_equal(aacmm_enc_decode(&c, &f, &got, &warn), AACMM_ENC_FAULT_NONE);
        assert_int_equal(got, 0x2ABCDEFu);
        assert_int_equal(warn, 1u);
        /* bad configurations and arguments */
        c.bits = 0u;
        assert_int_equal(aacmm_enc_decode(&c, &f, &got, &warn), AACMM_ENC_FAULT_FRAMING);
        assert_int_equal(aacmm_enc_clocks(&c), 0u);
        c.bits = 33u;
        assert_int_equal(aacmm_enc_config_validate(&c), AACMM_ERR_RANGE);
        c.bits = 8u;
        c.interface = AACMM_ENC_COUNTS;
        assert_int_equal(aacmm_enc_config_validate(&c), AACMM_ERR_RANGE);
        assert_int_equal(aacmm_enc_config_validate(NULL), AACMM_ERR_NULL);
        assert_int_equal(aacmm_enc_decode(NULL, &f, &got, &warn), AACMM_ENC_FAULT_FRAMING);
        c.interface = AACMM_ENC_BISS_C;
        assert_int_equal(aacmm_enc_decode(&c, NULL, &got, &warn), AACMM_ENC_FAULT_FRAMING);
        assert_int_equal(aacmm_enc_decode(&c, &f, NULL, &warn), AACMM_ENC_FAULT_FRAMING);
        /* n_bits beyond the buffer is clamped, never read past it */
        memset(&f, 0x55, sizeof f);
        f.n_bits = 255u;
        (void)aacmm_enc_decode(&c, &f, &got, &warn);
    }
    /* The CRC-6 against its definition: remainder of data * x^6 mod x^6+x+1. */
    assert_int_equal(aacmm_biss_crc6(0u, 34u), 0u);
    assert_int_equal(aacmm_biss_crc6(1u, 1u), 0x03u); /* x^6 mod p = x + 1 */
    assert_int_equal(aacmm_biss_crc6(2u, 2u), 0x06u); /* x^7 mod p = x^2 + x */
    assert_int_equal(aacmm_gray_to_binary(0x80000000u), 0xFFFFFFFFu);
    assert_int_equal(aacmm_gray_to_binary(0x3u), 0x2u);
    assert_int_equal(aacmm_sim_bits_for_cpr(2u), 1u);
    assert_int_equal(aacmm_sim_bits_for_cpr(1000u), 10u);
    assert_int_equal(aacmm_sim_bits_for_cpr(1024u), 10u);
    assert_int_equal(aacmm_sim_bits_for_cpr(UINT64_C(1) << 32), 32u);
}

/* Through the device: frames decoded per joint configuration, every fault
 * counted per joint with its kind, never a point from a bad frame. */
static void test_device_decodes_frames(void **state)
{
    aacmm_sim_encoders_t enc;
    aacmm_sim_encoders_config_t ec;
    uint32_t counts[AACMM_JOINTS_MAX] = {0x01000000u, 0x40000000u, 0x7FFFFF00u, 5u, 0xFFFFFFFFu, 0u};
    uint32_t faults = 0u;
    uint32_t points = 0u;
    uint32_t seen_warnings = 0u;
    unsigned k;
    int j;
    (void)state;
    memset(&ec, 0, sizeof ec);
    for (j = 0; j < AACMM_JOINTS; j++) {
        ec.joint[j].interface = j < 2 ? AACMM_ENC_BISS_C : (j < 4 ? AACMM_ENC_SSI_BINARY
                                                                   : AACMM_ENC_SSI_GRAY);
        ec.joint[j].bits = 32u;
    }
    ec.fault_every = 13u;
    ec.seed = 4u;
    assert_int_equal(aacmm_sim_encoders_init(&enc, &ec), AACMM_OK);
    setup_links(1, 0, 0, 0, 0);
    fake_use_frames(&F, &PF);
    /* an invalid joint configuration is refused */
    assert_int_equal(aacmm_device_init(&D, &CFG, &PF), AACMM_ERR_RANGE);
    for (j = 0; j < AACMM_JOINTS; j++) {
        CFG.encoders[j] = ec.joint[j];
    }
    boot();
    for (k = 0; k < 300u; k++) {
        uint32_t bad;
        assert_int_equal(aacmm_sim_encoders_frames(&enc, counts, F.frames), AACMM_OK);
        send_simple(AACMM_MSG_MEASURE_REQ, (uint8_t)k);
        expect_response(AACMM_MSG_MEASURE_RSP, (uint8_t)k);
        bad = M.u.sample.status & AACMM_SAMPLE_JOINT_FAULTS;
        if (bad != 0u) {
            faults++;
            assert_int_equal(M.u.sample.status & AACMM_SAMPLE_POINT_VALID, 0u);
            assert_true((M.u.sample.status & AACMM_SAMPLE_ENCODER_FAULT) != 0u);
            for (j = 0; j < AACMM_JOINTS; j++) {
                if ((bad & AACMM_SAMPLE_JOINT_FAULT(j)) != 0u) {
                    assert_int_equal(M.u.sample.counts[j], 0u);
                } else {
                    assert_int_equal(M.u.sample.counts[j], counts[j]);
                }
            }
        } else {
            points++;
            assert_true((M.u.sample.status & AACMM_SAMPLE_POINT_VALID) != 0u);
            assert_memory_equal(M.u.sample.counts, counts, sizeof counts);
        }
        if ((M.u.sample.status & AACMM_SAMPLE_ENCODER_WARNING) != 0u) {
            seen_warnings++;
        }
    }
    /* One frame in 13 of 1800 was corrupted; warnings are not faults. */
    diag(1);
    {
        uint32_t injected_faults = 0u;
        uint32_t sum = 0u;
        for (k = 1u; k < AACMM_SIM_ENC_KINDS; k++) {
            if (k != AACMM_SIM_ENC_WARNING) {
                injected_faults += enc.injected[k];
            }
        }
        for (j = 0; j < AACMM_JOINTS; j++) {
            sum += M.u.diag.joint[j].faults;
            assert_int_equal(M.u.diag.joint[j].interface, ec.joint[j].interface);
            assert_int_equal(M.u.diag.joint[j].bits, 32u);
            assert_true(M.u.diag.joint[j].faults > 0u);
        }
        assert_int_equal(injected_faults + enc.injected[AACMM_SIM_ENC_WARNING], 1800u / 13u);
        assert_int_equal(sum, injected_faults);
        assert_int_equal(M.u.diag.joint[0].warnings + M.u.diag.joint[1].warnings,
                         enc.injected[AACMM_SIM_ENC_WARNING]);
        assert_int_equal(seen_warnings, enc.injected[AACMM_SIM_ENC_WARNING]);
        assert_int_equal(M.u.diag.encoder_faults, faults);
        assert_int_equal(faults + points, 300u);
        assert_true(points > 100u);
    }
    /* A read failure is a READ fault on every joint. */
    F.encoder_status = AACMM_ERR_IO;
    send_simple(AACMM_MSG_MEASURE_REQ, 1);
    expect_response(AACMM_MSG_MEASURE_RSP, 1);
    assert_int_equal(M.u.sample.status & AACMM_SAMPLE_JOINT_FAULTS, 0x3F00u); /* joints 1..6 */
    diag(2);
    assert_int_equal(M.u.diag.joint[3].last_fault, AACMM_ENC_FAULT_READ);
    /* A count the sim cannot send in the configured width is refused. */
    ec.joint[0].bits = 8u;
    assert_int_equal(aacmm_sim_encoders_init(&enc, &ec), AACMM_OK);
    counts[0] = 256u;
    assert_int_equal(aacmm_sim_encoders_frames(&enc, counts, F.frames), AACMM_ERR_RANGE);
    ec.joint[2].interface = AACMM_ENC_COUNTS;
    assert_int_equal(aacmm_sim_encoders_init(&enc, &ec), AACMM_ERR_RANGE);
}

/* Flash: a power cut at every byte of the erase + write sequence leaves the
 * old set or the new one, never a mixed one. */
static void test_power_cut_flash_erase_and_write(void **state)
{
    aacmm_param_set_t old_set;
    aacmm_param_set_t new_set;
    uint8_t rec[AACMM_STORE_RECORD_BYTES];
    uint8_t before[AACMM_STORE_BYTES];
    long cut;
    long total = (long)AACMM_STORE_SLOT_BYTES + PAPER_RECORD_LEN;
    unsigned olds = 0u;
    (void)state;
    setup_links(1, 0, 1, 0, 0);
    fake_use_flash(&F, &PF);
    other_set(&old_set, 111.0);
    other_set(&new_set, 222.0);
    assert_int_equal(aacmm_store_save(&PF, &old_set, NULL, rec), AACMM_OK);
    assert_int_equal(aacmm_store_save(&PF, &old_set, NULL, rec), AACMM_OK); /* both slots */
    assert_int_equal(F.storage_erases, 2u);
    memcpy(before, F.storage, sizeof before);
    for (cut = 0; cut <= total; cut++) {
        aacmm_status_t st;
        memcpy(F.storage, before, sizeof before);
        F.write_budget = cut;
        st = aacmm_store_save(&PF, &new_set, NULL, rec);
        F.write_budget = -1;
        assert_int_equal(st == AACMM_OK, cut == total);
        setup_links(1, 0, 1, 0, 1);
        fake_use_flash(&F, &PF);
        boot();
        assert_int_equal(D.storage_state, AACMM_STORAGE_OK);
        if (D.active_crc32 == set_crc(&old_set)) {
            olds++;
        } else {
            assert_int_equal(D.active_crc32, set_crc(&new_set));
        }
        if (cut > 0 && cut < (long)AACMM_STORE_SLOT_BYTES) {
            /* cut inside the erase: that slot is neither record */
            assert_true(D.store.slot_state[0] != AACMM_SLOT_OLDER &&
                        D.store.slot_state[0] != AACMM_SLOT_NEWEST);
        }
    }
    assert_int_equal(olds, (unsigned)total);
}

static void test_sim_init_errors(void **state)
{
    aacmm_sim_t s;
    aacmm_sim_config_t c;
    static const uint32_t poses[12] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 4096};
    (void)state;
    sim_cfg(&c, AACMM_SIM_WALK, 1);
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_ERR_RANGE);
    c.counts_per_rev = (UINT64_C(1) << 32) + 1u;
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_ERR_RANGE);
    c.counts_per_rev = 4096;
    c.noise_counts = AACMM_SIM_NOISE_MAX + 1u;
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_ERR_RANGE);
    c.noise_counts = 0;
    c.motion = (aacmm_sim_motion_t)9;
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_ERR_RANGE);
    c.motion = AACMM_SIM_REPLAY;
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_ERR_NULL);
    c.replay = poses;
    c.replay_poses = 2;
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_ERR_RANGE); /* 4096 >= cpr */
    c.replay_poses = 1;
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_OK);
    assert_int_equal(aacmm_sim_init(NULL, &c), AACMM_ERR_NULL);
}

static void test_sim_static_repeatable(void **state)
{
    aacmm_sim_t a;
    aacmm_sim_t b;
    aacmm_sim_config_t c;
    uint32_t x[AACMM_JOINTS_MAX];
    uint32_t y[AACMM_JOINTS_MAX];
    (void)state;
    sim_cfg(&c, AACMM_SIM_STATIC, UINT64_C(1) << 20);
    assert_int_equal(aacmm_sim_init(&a, &c), AACMM_OK);
    c.seed = 99;
    assert_int_equal(aacmm_sim_init(&b, &c), AACMM_OK);
    assert_int_equal(aacmm_sim_read(&a, 0, x), AACMM_OK);
    assert_int_equal(aacmm_sim_read(&b, 123456789u, y), AACMM_OK);
    assert_memory_equal(x, y, sizeof x);
    /* Joint 0 at 0.5 rad: 0.5 / 2 pi * 2^20 = 83443.0 counts. */
    assert_true(count_dist(x[0], 83443u, UINT64_C(1) << 20) <= 1u);
    /* Joint 5 at -0.3 rad wraps below zero. */
    assert_true(x[5] > (1u << 19));
}

static void test_sim_angle_to_counts(void **state)
{
    (void)state;
    assert_int_equal(aacmm_sim_angle_to_counts(0.0f, 4096), 0u);
    assert_int_equal(aacmm_sim_angle_to_counts(1.5707964f, 4096), 1024u);
    assert_int_equal(aacmm_sim_angle_to_counts(-1.5707964f, 4096), 3072u);
    assert_int_equal(aacmm_sim_angle_to_counts(3.1415927f, 4096), 2048u);
    assert_int_equal(aacmm_sim_angle_to_counts(-1.5707964f, UINT64_C(1) << 32), 0xC0000000u);
    assert_int_equal(aacmm_sim_angle_to_counts(0.0f, 3600), 0u);
    assert_int_equal(aacmm_sim_angle_to_counts(-0.0017453292f, 3600), 3599u); /* -0.1 deg */
    assert_int_equal(aacmm_sim_angle_to_counts(6.2831853f, 3600), 0u);
}

static void test_sim_sweep_and_walk_smooth(void **state)
{
    static const aacmm_sim_motion_t motions[2] = {AACMM_SIM_SWEEP, AACMM_SIM_WALK};
    int mi;
    (void)state;
    for (mi = 0; mi < 2; mi++) {
        aacmm_sim_t s;
        aacmm_sim_config_t c;
        float prev[AACMM_JOINTS];
        float th[AACMM_JOINTS];
        float lo[AACMM_JOINTS];
        float hi[AACMM_JOINTS];
        uint64_t t;
        int j;
        sim_cfg(&c, motions[mi], UINT64_C(1) << 32);
        assert_int_equal(aacmm_sim_init(&s, &c), AACMM_OK);
        assert_int_equal(aacmm_sim_angles(&s, 0, prev), AACMM_OK);
        for (j = 0; j < AACMM_JOINTS; j++) {
            lo[j] = hi[j] = prev[j];
        }
        for (t = 10000u; t <= 120000000u; t += 10000u) {
            assert_int_equal(aacmm_sim_angles(&s, t, th), AACMM_OK);
            for (j = 0; j < AACMM_JOINTS; j++) {
                float d = th[j] - prev[j];
                /* smooth: under 4 rad/s, i.e. 0.04 rad per 10 ms */
                assert_true(d < 0.04f && d > -0.04f);
                assert_true(th[j] > -3.3f && th[j] < 3.3f);
                if (th[j] < lo[j]) {
                    lo[j] = th[j];
                }
                if (th[j] > hi[j]) {
                    hi[j] = th[j];
                }
                prev[j] = th[j];
            }
        }
        /* every joint really moves through a good part of its range */
        for (j = 0; j < AACMM_JOINTS; j++) {
            assert_true(hi[j] - lo[j] > 1.0f);
        }
    }
}

static void test_sim_walk_seeded(void **state)
{
    aacmm_sim_t a;
    aacmm_sim_t b;
    aacmm_sim_config_t c;
    float x[AACMM_JOINTS];
    float y[AACMM_JOINTS];
    (void)state;
    sim_cfg(&c, AACMM_SIM_WALK, 4096);
    c.seed = 5;
    assert_int_equal(aacmm_sim_init(&a, &c), AACMM_OK);
    assert_int_equal(aacmm_sim_init(&b, &c), AACMM_OK);
    assert_int_equal(aacmm_sim_angles(&a, 7777777u, x), AACMM_OK);
    assert_int_equal(aacmm_sim_angles(&b, 7777777u, y), AACMM_OK);
    assert_memory_equal(x, y, sizeof x);
    c.seed = 6;
    assert_int_equal(aacmm_sim_init(&b, &c), AACMM_OK);
    assert_int_equal(aacmm_sim_angles(&b, 7777777u, y), AACMM_OK);
    assert_memory_not_equal(x, y, sizeof x);
    /* Passes through waypoints: continuous across a segment boundary. */
    assert_int_equal(aacmm_sim_angles(&a, AACMM_SIM_WALK_SEGMENT_US - 1u, x), AACMM_OK);
    assert_int_equal(aacmm_sim_angles(&a, AACMM_SIM_WALK_SEGMENT_US, y), AACMM_OK);
    assert_true(x[0] - y[0] < 1e-4f && y[0] - x[0] < 1e-4f);
}

static void test_sim_noise_bounds(void **state)
{
    aacmm_sim_t s;
    aacmm_sim_config_t c;
    uint32_t clean[AACMM_JOINTS_MAX];
    uint32_t noisy[AACMM_JOINTS_MAX];
    uint32_t maxd = 0;
    int k;
    int j;
    (void)state;
    sim_cfg(&c, AACMM_SIM_STATIC, 4096);
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_OK);
    assert_int_equal(aacmm_sim_read(&s, 0, clean), AACMM_OK);
    c.noise_counts = 3;
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_OK);
    for (k = 0; k < 2000; k++) {
        assert_int_equal(aacmm_sim_read(&s, 0, noisy), AACMM_OK);
        for (j = 0; j < AACMM_JOINTS; j++) {
            uint32_t d = count_dist(noisy[j], clean[j], 4096);
            assert_true(noisy[j] < 4096u);
            assert_true(d <= 3u);
            if (d > maxd) {
                maxd = d;
            }
        }
    }
    assert_int_equal(maxd, 3u); /* the full range is used */
}

static void test_sim_replay_loops(void **state)
{
    aacmm_sim_t s;
    aacmm_sim_config_t c;
    static const uint32_t poses[18] = {1, 2, 3, 4, 5, 6, 10, 20, 30, 40, 50, 60,
                                       100, 200, 300, 400, 500, 600};
    uint32_t got[AACMM_JOINTS_MAX];
    float th[AACMM_JOINTS];
    int k;
    (void)state;
    sim_cfg(&c, AACMM_SIM_REPLAY, 4096);
    c.replay = poses;
    c.replay_poses = 3;
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_OK);
    for (k = 0; k < 7; k++) {
        assert_int_equal(aacmm_sim_read(&s, 0, got), AACMM_OK);
        assert_memory_equal(got, poses + (k % 3) * 6, AACMM_JOINTS * sizeof got[0]);
    }
    assert_int_equal(aacmm_sim_angles(&s, 0, th), AACMM_ERR_UNSUPPORTED);
}

/* Replays of 4, 5 and 7 joints (replay_joints): joints 1..K from the pose,
 * 0 past K, joint 7 held at 0.7 rad unless K = 7; noise on joints 1..K in
 * joint order, so K = 6 given as 6 or as 0 gives the same readings. */
static void test_sim_replay_joints(void **state)
{
    aacmm_sim_t s;
    aacmm_sim_t t;
    aacmm_sim_config_t c;
    static const uint32_t poses[14] = {1, 2, 3, 4, 5, 6, 7, 10, 20, 30, 40, 50, 60, 4095};
    uint32_t got[AACMM_JOINTS_MAX];
    uint32_t ref[AACMM_JOINTS_MAX];
    uint32_t hold7;
    unsigned k;
    int i;
    int r;
    (void)state;
    sim_cfg(&c, AACMM_SIM_REPLAY, 4096);
    hold7 = aacmm_sim_angle_to_counts(0.7f, 4096);
    c.replay = poses;
    for (k = 4; k <= 7; k++) {
        c.replay_joints = (uint8_t)k;
        c.replay_poses = 14u / k;
        assert_int_equal(aacmm_sim_init(&s, &c), AACMM_OK);
        for (r = 0; r < 5; r++) {
            const uint32_t *pose = poses + (size_t)((unsigned)r % (14u / k)) * k;
            assert_int_equal(aacmm_sim_read(&s, 0, got), AACMM_OK);
            for (i = 0; i < AACMM_JOINTS_MAX; i++) {
                uint32_t want = (unsigned)i < k ? pose[i] : (i == 6 ? hold7 : 0u);
                assert_int_equal(got[i], want);
            }
        }
    }
    /* out of range */
    c.replay_poses = 1;
    c.replay_joints = 3;
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_ERR_RANGE);
    c.replay_joints = 8;
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_ERR_RANGE);
    c.replay_joints = 7;
    c.replay_poses = 2; /* the second pose's joint 7 is 4095 < 4096: fine */
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_OK);
    c.counts_per_rev = 4095; /* now it is not */
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_ERR_RANGE);
    /* with noise: 6 as 0 or 6 the same stream; 7 keeps joints 1..6's noise */
    sim_cfg(&c, AACMM_SIM_REPLAY, 4096);
    c.replay = poses;
    c.noise_counts = 50;
    c.seed = 11;
    c.replay_poses = 2;
    c.replay_joints = 0;
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_OK);
    c.replay_joints = 6;
    assert_int_equal(aacmm_sim_init(&t, &c), AACMM_OK);
    for (r = 0; r < 6; r++) {
        assert_int_equal(aacmm_sim_read(&s, 0, ref), AACMM_OK);
        assert_int_equal(aacmm_sim_read(&t, 0, got), AACMM_OK);
        assert_memory_equal(got, ref, sizeof got);
    }
    /* 7: joints 1..6 draw the noise of 6 (pose 1's first six are the same),
     * then joint 7 its own from the pose's 7 */
    c.replay_joints = 7;
    assert_int_equal(aacmm_sim_init(&t, &c), AACMM_OK);
    c.replay_joints = 0;
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_OK);
    assert_int_equal(aacmm_sim_read(&s, 0, ref), AACMM_OK);
    assert_int_equal(aacmm_sim_read(&t, 0, got), AACMM_OK);
    assert_memory_equal(got, ref, AACMM_JOINTS * sizeof got[0]);
    assert_true(count_dist(got[6], 7u, 4096) <= 50u);
    assert_int_equal(ref[6], hold7);
}

static void test_sim_button(void **state)
{
    aacmm_sim_t s;
    aacmm_sim_config_t c;
    (void)state;
    sim_cfg(&c, AACMM_SIM_STATIC, 4096);
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_OK);
    assert_int_equal(aacmm_sim_button(&s, 5000000u), 0);
    c.button_period_us = 2000000u;
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_OK);
    assert_int_equal(aacmm_sim_button(&s, 0), 0);
    assert_int_equal(aacmm_sim_button(&s, 100000u), 0);
    assert_int_equal(aacmm_sim_button(&s, 1999999u), 0);
    assert_int_equal(aacmm_sim_button(&s, 2000000u), 1);
    assert_int_equal(aacmm_sim_button(&s, 2199999u), 1);
    assert_int_equal(aacmm_sim_button(&s, 2200000u), 0);
    assert_int_equal(aacmm_sim_button(&s, 4100000u), 1);
    assert_int_equal(aacmm_sim_next_button_edge_us(&s, 0), 2000000u);
    assert_int_equal(aacmm_sim_next_button_edge_us(&s, 2000000u), 2200000u);
    assert_int_equal(aacmm_sim_next_button_edge_us(&s, 2100000u), 2200000u);
    assert_int_equal(aacmm_sim_next_button_edge_us(&s, 2200000u), 4000000u);
    c.button_period_us = 100000u; /* short period: held half of it */
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_OK);
    assert_int_equal(aacmm_sim_button(&s, 149999u), 1);
    assert_int_equal(aacmm_sim_button(&s, 150000u), 0);
    {
        /* Every change happens exactly at a reported edge. */
        uint64_t t = 0;
        uint64_t edge = aacmm_sim_next_button_edge_us(&s, 0);
        uint8_t level = aacmm_sim_button(&s, 0);
        for (t = 1; t < 1000000u; t += 7) {
            uint8_t now = aacmm_sim_button(&s, t);
            if (now != level) {
                assert_true(t >= edge && t < edge + 7u);
                level = now;
            }
            if (t >= edge) {
                edge = aacmm_sim_next_button_edge_us(&s, t);
            }
        }
    }
    c.button_period_us = 0;
    assert_int_equal(aacmm_sim_init(&s, &c), AACMM_OK);
    assert_true(aacmm_sim_next_button_edge_us(&s, 5u) == UINT64_MAX);
}

/* The simulated arm as the device's encoders: the counts it produces are
 * valid for the device's default encoder configuration. */
static aacmm_sim_t sim_for_device;
static aacmm_status_t sim_read(void *ctx, uint32_t counts[AACMM_JOINTS_MAX])
{
    (void)ctx;
    return aacmm_sim_read(&sim_for_device, F.now_us, counts);
}

static void test_sim_drives_device(void **state)
{
    aacmm_sim_config_t c;
    aacmm_param_set_t def;
    int k;
    int i;
    (void)state;
    sim_cfg(&c, AACMM_SIM_WALK, 3600);
    c.noise_counts = 2;
    assert_int_equal(aacmm_sim_init(&sim_for_device, &c), AACMM_OK);
    setup_links(1, 0, 0, 0, 0);
    PF.read_encoders = sim_read;
    default_set(&def);
    for (i = 0; i < AACMM_JOINTS; i++) {
        def.enc.counts_per_rev[i] = 3600u;
    }
    CFG.defaults = &def;
    boot();
    start_stream(100, 0);
    for (k = 0; k < 500; k++) {
        advance(10000u);
        aacmm_device_poll(&D);
    }
    k = 0;
    while (next_msg()) {
        assert_true((M.u.sample.status & AACMM_SAMPLE_POINT_VALID) != 0u);
        k++;
    }
    assert_int_equal(k, 501);
    assert_int_equal(aacmm_device_counters(&D)->encoder_faults, 0u);
}

/* ------------------------------------------------------------------------ */
/* link temperatures (issue 27)                                              */
/* ------------------------------------------------------------------------ */

/* A device whose platform reads link temperatures (every link at 20.00
 * degC, valid, until the test changes F.temp / temp_valid / temp_status). */
static int setup_temps(void **state)
{
    (void)state;
    setup_links(1, 1, 1, 1, 0);
    fake_use_temperatures(&F, &PF);
    boot();
    return 0;
}

/* The paper's arm with the thermal block (aluminium-like CTEs, one link of
 * a smaller one, tref 20 degC) and K = 1 on two joints. */
static void thermal_set(aacmm_param_set_t *s, int16_t ref_temp)
{
    int i;
    default_set(s);
    s->err.thermal = 1u;
    s->err.ref_temp = ref_temp;
    for (i = 0; i < 6; i++) {
        s->err.cte[i] = (int16_t)(2300 - 250 * i); /* 23e-6 .. 10.5e-6 / K */
    }
    s->err.harmonics[1] = 1u;
    s->err.harm_cos[1][0] = 1500;
    s->err.harmonics[4] = 1u;
    s->err.harm_sin[4][0] = -900;
}

/* MEASURE with content into M (a response, checked). */
static void measure(uint8_t content, uint8_t seq)
{
    aacmm_msg_t m;
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_MEASURE_REQ;
    m.seq = seq;
    m.u.measure.content = content;
    send_msg(&m);
    expect_response(AACMM_MSG_MEASURE_RSP, seq);
}

/* The error model of a set in the core's double form, built here from the
 * wire units (aacmm/proto.h), not by the device's helper. */
static void ref_errmodel_f64(const aacmm_param_set_t *set, aacmm_errmodel_f64_t *e)
{
    int n = (int)set->arm.shape.joints;
    int i;
    int k;
    assert_int_equal(aacmm_errmodel_default_f64(e, n), AACMM_OK);
    for (i = 0; i < n; i++) {
        e->harmonics[i] = set->err.harmonics[i];
        for (k = 0; k < AACMM_HARMONICS_MAX; k++) {
            e->c_rad[i][k] = 1e-7 * (double)set->err.harm_cos[i][k];
            e->s_rad[i][k] = 1e-7 * (double)set->err.harm_sin[i][k];
        }
        if (set->err.thermal) {
            e->cte_per_k[i] = 1e-8 * (double)set->err.cte[i];
            e->tref_c[i] = 0.01 * (double)set->err.ref_temp;
        }
    }
}

/* The core's point (and first P columns of its extended Jacobian) of the
 * set at counts and link temperatures temp (0.01 degC; NULL: the reference
 * temperatures), computed here: f32, aacmm_point_em_f32 at temp / 100 (the
 * nearest float in degC); Q, aacmm_point_em_q at aacmm_temp_q8_from_f64.
 * mm: the point in mm as COMPUTE sends it; x_wire: the point in 1e-4 mm
 * before rounding (f32: as the wire rounds it, exact). */
static void core_point_at(const aacmm_param_set_t *set, const uint32_t *counts,
                          const int16_t *temp, double mm[3], float jac[AACMM_JAC_SIZE_MAX])
{
    int n = (int)set->arm.shape.joints;
    int np = aacmm_shape_params(&set->arm.shape);
    aacmm_errmodel_f64_t e64;
    int i;
    int r;
    ref_errmodel_f64(set, &e64);
#ifndef AACMM_DEVICE_KIN_FIXED
    {
        aacmm_arm_f32_t a32;
        aacmm_model_f32_t m32;
        aacmm_errmodel_f32_t e32;
        float th[AACMM_JOINTS_MAX];
        float tc[AACMM_JOINTS_MAX];
        float p[3];
        float pj[3];
        static float ext[AACMM_EXT_JAC_SIZE_MAX];
        int w;
        a32.shape = set->arm.shape;
        for (i = 0; i < AACMM_JOINTS_MAX; i++) {
            a32.theta_offset_rad[i] = (float)set->arm.theta_offset_rad[i];
            a32.alpha_rad[i] = (float)set->arm.alpha_rad[i];
            a32.d_mm[i] = (float)set->arm.d_mm[i];
            a32.a_mm[i] = (float)set->arm.a_mm[i];
            a32.beta_rad[i] = (float)set->arm.beta_rad[i];
        }
        for (i = 0; i < 3; i++) {
            a32.tip_mm[i] = (float)set->arm.tip_mm[i];
        }
        assert_int_equal(aacmm_model_init_arm_f32(&m32, &a32), AACMM_OK);
        assert_int_equal(aacmm_errmodel_default_f32(&e32, n), AACMM_OK);
        for (i = 0; i < n; i++) {
            int k;
            e32.harmonics[i] = e64.harmonics[i];
            for (k = 0; k < AACMM_HARMONICS_MAX; k++) {
                e32.c_rad[i][k] = (float)e64.c_rad[i][k];
                e32.s_rad[i][k] = (float)e64.s_rad[i][k];
            }
            e32.cte_per_k[i] = (float)e64.cte_per_k[i];
            e32.tref_c[i] = (float)e64.tref_c[i];
            if (temp != NULL) {
                tc[i] = (float)temp[i] / 100.0f;
            }
        }
        assert_int_equal(aacmm_arm_encoders_to_angles_f32(&set->enc, counts, th), AACMM_OK);
        assert_int_equal(aacmm_point_em_f32(&m32, &e32, th, temp != NULL ? tc : NULL, p),
                         AACMM_OK);
        assert_int_equal(aacmm_point_jacobian_em_f32(&m32, &e32, th, temp != NULL ? tc : NULL, pj,
                                                     ext),
                         AACMM_OK);
        assert_memory_equal(p, pj, sizeof p);
        w = np + aacmm_errmodel_cols_f32(&e32);
        for (i = 0; i < 3; i++) {
            mm[i] = (double)p[i];
        }
        for (r = 0; r < 3; r++) {
            for (i = 0; i < np; i++) {
                jac[r * np + i] = ext[r * w + i];
            }
        }
    }
#else
    {
        aacmm_arm_q_t aq;
        aacmm_model_q_t mq;
        aacmm_errmodel_q_t eq;
        uint32_t bam[AACMM_JOINTS_MAX];
        double tc[AACMM_JOINTS_MAX];
        int32_t tq[AACMM_JOINTS_MAX];
        int64_t p[3];
        int64_t pj[3];
        int64_t jq[AACMM_JAC_SIZE_MAX];
        assert_int_equal(aacmm_arm_q_from_f64(&aq, &set->arm), AACMM_OK);
        assert_int_equal(aacmm_model_q_init_arm(&mq, &aq), AACMM_OK);
        assert_int_equal(aacmm_errmodel_q_from_f64(&eq, &e64), AACMM_OK);
        assert_int_equal(aacmm_arm_encoders_to_bam(&set->enc, counts, bam), AACMM_OK);
        if (temp != NULL) {
            for (i = 0; i < n; i++) {
                tc[i] = (double)temp[i] / 100.0;
            }
            assert_int_equal(aacmm_temp_q8_from_f64(tq, tc, (size_t)n), AACMM_OK);
        }
        assert_int_equal(aacmm_point_em_q(&mq, &eq, bam, temp != NULL ? tq : NULL, p), AACMM_OK);
        assert_int_equal(aacmm_point_jacobian_corrected_q(&mq, &eq, bam, temp != NULL ? tq : NULL,
                                                          pj, jq),
                         AACMM_OK);
        assert_memory_equal(p, pj, sizeof p);
        for (i = 0; i < 3; i++) {
            mm[i] = (double)p[i] * 3.552713678800501e-15; /* 2^-48 */
        }
        (void)r;
        for (i = 0; i < 3 * np; i++) {
            jac[i] = (float)jq[i] * 3.5527137e-15f;
        }
    }
#endif
}

/* A sample's wire point is the core's point mm rounded to 1e-4 mm. */
static void assert_wire_point(const int32_t wire[3], const double mm[3])
{
    int i;
    for (i = 0; i < 3; i++) {
#ifndef AACMM_DEVICE_KIN_FIXED
        assert_int_equal(wire[i], aacmm_point_mm_to_wire(mm[i], NULL));
#else
        /* the exact integer rounding of the Q48 point: within half a unit
         * of the (double) point, 1e-8 units of slack for the double */
        double x = mm[i] * 1e4;
        assert_true(fabs((double)wire[i] - x) <= 0.5 + 1e-6);
#endif
    }
}

static void test_temps_info_flag(void **state)
{
    (void)state;
    send_simple(AACMM_MSG_INFO_REQ, 1);
    expect_response(AACMM_MSG_INFO_RSP, 1);
    assert_int_equal(M.u.info.build_flags, KIN_FLAGS | AACMM_BUILD_JACOBIAN | AACMM_BUILD_SERIAL |
                                               AACMM_BUILD_CAN | AACMM_BUILD_TEMPERATURES);
    assert_int_equal(aacmm_device_build_flags(&D) & AACMM_BUILD_TEMPERATURES,
                     AACMM_BUILD_TEMPERATURES);
    /* the same device without sensors: no flag */
    setup_links(1, 1, 1, 1, 0);
    boot();
    assert_int_equal(aacmm_device_build_flags(&D) & AACMM_BUILD_TEMPERATURES, 0u);
}

/* The thermal block in force: every sample's point is the core's at the
 * link temperatures, through changes of temperature and back (the cached
 * model follows), with and without the Jacobian; one reading per sample. */
static void test_temps_thermal_point(void **state)
{
    static const int16_t temps[5][AACMM_JOINTS_MAX] = {
        {2000, 2000, 2000, 2000, 2000, 2000, 0},    /* the reference: nothing scaled */
        {4500, 4500, 4500, 4500, 4500, 4500, 0},    /* 25 K warmer */
        {3125, 2850, -1050, 6025, 2000, 8500, 0},   /* per link, one at the top */
        {-4000, 1, -1, 3999, 7777, 4500, 0},        /* the bottom, 0.01 degC steps */
        {4500, 4500, 4500, 4500, 4500, 4500, 0},    /* back: the point of before */
    };
    static const uint32_t counts[AACMM_JOINTS] = {0x12345678u, 0xE0000000u, 0x30000000u,
                                                  0xF0000000u, 0x2AAAAAABu, 0x9ABCDEF0u};
    aacmm_param_set_t set;
    double want[3];
    double ref[3];
    double warm[3];
    float jac[AACMM_JAC_SIZE_MAX];
    int np;
    int k;
    int i;
    (void)state;
    thermal_set(&set, 2000);
    np = aacmm_shape_params(&set.arm.shape);
    set_params(&set, 2);
    memcpy(F.counts, counts, sizeof counts);
    for (k = 0; k < 5; k++) {
        unsigned reads;
        memcpy(F.temp, temps[k], sizeof F.temp);
        core_point_at(&set, counts, temps[k], want, jac);
        reads = F.temp_reads;
        measure(0, (uint8_t)(10 + k));
        assert_int_equal(F.temp_reads, reads + 1u);
        assert_int_equal(M.u.sample.status, AACMM_SAMPLE_POINT_VALID);
        assert_wire_point(M.u.sample.point_100nm, want);
        measure(AACMM_CONTENT_JACOBIAN, (uint8_t)(20 + k));
        assert_int_equal(M.u.sample.status, AACMM_SAMPLE_POINT_VALID);
        assert_wire_point(M.u.sample.point_100nm, want);
        assert_memory_equal(M.u.sample.jacobian, jac, (size_t)(3 * np) * sizeof(float));
        if (k == 0) {
            memcpy(ref, want, sizeof ref);
        }
        if (k == 1) {
            memcpy(warm, want, sizeof warm);
        }
        if (k == 4) {
            assert_memory_equal(want, warm, sizeof want);
        }
    }
    /* 25 K on ~1.2 m of aluminium-like links moves the tip by far more
     * than the wire's resolution */
    {
        double d = 0.0;
        for (i = 0; i < 3; i++) {
            d += (warm[i] - ref[i]) * (warm[i] - ref[i]);
        }
        assert_true(sqrt(d) > 0.2);
    }
    /* COMPUTE without temperatures: at the reference temperatures */
    {
        aacmm_msg_t m;
        double at_ref[3];
        core_point_at(&set, counts, NULL, at_ref, jac);
        memset(&m, 0, sizeof m);
        m.type = AACMM_MSG_COMPUTE_REQ;
        m.seq = 30;
        m.u.compute_req.content = AACMM_CONTENT_JACOBIAN;
        m.u.compute_req.joints = 6;
        memcpy(m.u.compute_req.counts, counts, sizeof counts);
        send_msg(&m);
        expect_response(AACMM_MSG_COMPUTE_RSP, 30);
        assert_memory_equal(M.u.compute_rsp.point_mm, at_ref, sizeof at_ref);
        assert_memory_equal(M.u.compute_rsp.jacobian, jac, (size_t)(3 * np) * sizeof(float));
        /* the same as at 20.00 degC on every link = tref (not scaled) */
        assert_memory_equal(ref, at_ref, sizeof ref);
    }
    /* another thermal set at the same temperatures: its own point (the
     * cached model of the previous set is not used) */
    thermal_set(&set, 2500);
    set.err.cte[2] = -1200;
    set_params(&set, 31);
    core_point_at(&set, counts, temps[4], want, jac);
    measure(0, 32);
    assert_wire_point(M.u.sample.point_100nm, want);
}

/* With the thermal block, a sample whose temperatures are not good has no
 * point: TEMP_FAULT, POINT_VALID clear, point and Jacobian 0, not an
 * encoder fault; temp_faults counts every one. */
static void test_temps_fault_thermal(void **state)
{
    aacmm_param_set_t set;
    aacmm_msg_diag_t diag;
    uint32_t faults = 0u;
    int c;
    int i;
    (void)state;
    thermal_set(&set, 2000);
    set_params(&set, 2);
    for (c = 0; c < 7; c++) {
        int good = 0;
        fake_use_temperatures(&F, &PF);
        switch (c) {
        case 0: F.temp_valid = (uint8_t)(0x7Fu & ~(1u << 3)); break; /* link 4 does not answer */
        case 1: F.temp[0] = 8501; break;                              /* above 85 degC */
        case 2: F.temp[5] = -4001; break;                             /* below -40 degC */
        case 3: F.temp_status = AACMM_ERR_IO; break;                  /* no reading at all */
        case 4: F.temp_valid = 0u; break;                             /* none valid */
        case 5: F.temp[0] = 8500; F.temp[5] = -4000; good = 1; break; /* the limits: good */
        default: F.temp_valid = 0x3Fu; F.temp[6] = AACMM_TEMP_NONE; good = 1; break; /* link 7: not the arm's */
        }
        measure(AACMM_CONTENT_JACOBIAN, (uint8_t)(10 + c));
        if (good) {
            assert_int_equal(M.u.sample.status, AACMM_SAMPLE_POINT_VALID);
        } else {
            faults++;
            assert_int_equal(M.u.sample.status, AACMM_SAMPLE_TEMP_FAULT);
            for (i = 0; i < 3; i++) {
                assert_int_equal(M.u.sample.point_100nm[i], 0);
            }
            {
                static const float zero[AACMM_JAC_SIZE_MAX];
                assert_memory_equal(M.u.sample.jacobian, zero,
                                    (size_t)(3 * (int)M.u.sample.params) * sizeof(float));
            }
        }
        assert_int_equal(aacmm_device_diag(&D, &diag), AACMM_OK);
        assert_int_equal(diag.temp_faults, faults);
        assert_int_equal(diag.encoder_faults, 0u);
        assert_int_equal(aacmm_device_counters(&D)->temp_faults, faults);
    }
    assert_int_equal(faults, 5u);
    /* the stream's samples too */
    fake_use_temperatures(&F, &PF);
    F.temp_valid = 0x3Eu; /* link 1 */
    start_stream(100, 0);
    assert_true(next_msg());
    assert_int_equal(M.type, AACMM_MSG_SAMPLE_EVT);
    assert_int_equal(M.u.sample.status & (AACMM_SAMPLE_TEMP_FAULT | AACMM_SAMPLE_POINT_VALID),
                     AACMM_SAMPLE_TEMP_FAULT);
    assert_int_equal(aacmm_device_counters(&D)->temp_faults, faults + 1u);
}

/* Without the thermal block the temperatures are only reported and flagged:
 * the point is the one of a device without sensors, bit for bit. */
static void test_temps_fault_plain(void **state)
{
    static const uint32_t counts[AACMM_JOINTS] = {0x01234567u, 0x89ABCDEFu, 0x7FFFFFFFu,
                                                  0x80000000u, 0x00000001u, 0xFFFFFFFEu};
    aacmm_msg_t plain;
    aacmm_msg_diag_t diag;
    int c;
    (void)state;
    memcpy(F.counts, counts, sizeof counts);
    PF.read_temperatures = NULL; /* the same device without sensors */
    boot();
    measure(AACMM_CONTENT_JACOBIAN, 1);
    plain = M;
    fake_use_temperatures(&F, &PF);
    boot();
    for (c = 0; c < 4; c++) {
        fake_use_temperatures(&F, &PF);
        switch (c) {
        case 0: F.temp_valid = 0x5Fu; break;        /* link 6 */
        case 1: F.temp[2] = 9000; break;            /* hot */
        case 2: F.temp_status = AACMM_ERR_IO; break;
        default: F.temp[1] = 3000; break;           /* good: no flag */
        }
        measure(AACMM_CONTENT_JACOBIAN, (uint8_t)(2 + c));
        assert_int_equal(M.u.sample.status, plain.u.sample.status |
                                                (c < 3 ? AACMM_SAMPLE_TEMP_FAULT : 0u));
        assert_memory_equal(M.u.sample.point_100nm, plain.u.sample.point_100nm,
                            sizeof plain.u.sample.point_100nm);
        assert_memory_equal(M.u.sample.jacobian, plain.u.sample.jacobian,
                            sizeof plain.u.sample.jacobian);
    }
    assert_int_equal(aacmm_device_diag(&D, &diag), AACMM_OK);
    assert_int_equal(diag.temp_faults, 3u);
}

/* Sensors present, no thermal block, content without TEMPERATURES: the
 * bytes on the wire are those of a device without sensors. */
static void test_temps_bytes_unchanged(void **state)
{
    static uint8_t first[65536];
    size_t first_len = 0;
    int pass;
    (void)state;
    for (pass = 0; pass < 2; pass++) {
        aacmm_msg_t m;
        setup_links(1, 0, 1, 1, 0);
        if (pass == 1) {
            fake_use_temperatures(&F, &PF);
            F.temp[0] = 3750;
            F.temp[4] = -500;
        }
        boot();
        F.counts[0] = 0x40000000u;
        F.counts[3] = 0x12345678u;
        measure(0, 1);
        measure(AACMM_CONTENT_JACOBIAN, 2);
        memset(&m, 0, sizeof m);
        m.type = AACMM_MSG_COMPUTE_REQ;
        m.seq = 3;
        m.u.compute_req.content = AACMM_CONTENT_JACOBIAN;
        m.u.compute_req.joints = 6;
        m.u.compute_req.counts[1] = 0x30000000u;
        send_msg(&m);
        expect_response(AACMM_MSG_COMPUTE_RSP, 3);
        start_stream(1000, AACMM_CONTENT_JACOBIAN);
        advance(5000);
        aacmm_device_poll(&D);
        while (next_msg()) {
        }
        if (pass == 0) {
            assert_true(F.tx_len <= sizeof first);
            memcpy(first, F.tx, F.tx_len);
            first_len = F.tx_len;
        } else {
            assert_true(F.temp_reads >= 7u); /* two measures, six stream samples */
            assert_int_equal(F.tx_len, first_len);
            assert_memory_equal(F.tx, first, first_len);
        }
    }
}

/* A stored set with the thermal block on a device without sensors is not
 * used (defaults, said in INFO and DIAG); the same storage with sensors
 * uses it. */
static void test_temps_stored_thermal_set(void **state)
{
    aacmm_param_set_t set;
    aacmm_msg_diag_t diag;
    (void)state;
    thermal_set(&set, 2150);
    set_params(&set, 2);
    save_via_request(3);
    assert_int_equal(M.type, AACMM_MSG_SAVE_PARAMS_RSP);
    setup_links(1, 1, 1, 1, 1);
    boot(); /* no sensors */
    send_simple(AACMM_MSG_INFO_REQ, 4);
    expect_response(AACMM_MSG_INFO_RSP, 4);
    assert_int_equal(M.u.info.param_source, AACMM_PARAM_SOURCE_DEFAULTS);
    assert_int_equal(M.u.info.storage_state, AACMM_STORAGE_CORRUPT);
    assert_int_equal(aacmm_device_diag(&D, &diag), AACMM_OK);
    assert_true(diag.slot_state[0] == AACMM_SLOT_BAD_CONTENTS ||
                diag.slot_state[1] == AACMM_SLOT_BAD_CONTENTS);
    /* and SET_PARAMS of it is refused there */
    send_set_params(&set, 5);
    expect_error(AACMM_ERR_UNSUPPORTED, AACMM_MSG_SET_PARAMS_REQ, 5);
    setup_links(1, 1, 1, 1, 1);
    fake_use_temperatures(&F, &PF);
    boot();
    send_simple(AACMM_MSG_INFO_REQ, 6);
    expect_response(AACMM_MSG_INFO_RSP, 6);
    assert_int_equal(M.u.info.param_source, AACMM_PARAM_SOURCE_STORAGE);
    assert_int_equal(M.u.info.param_crc32, set_crc(&set));
}

/* Protocol version 4 on the wire: the TEMPERATURES content of MEASURE and
 * streams (serial; CAN as SAMPLE_EVT over ISO-TP), trigger events, DIAG's
 * temp_faults. The readings are sent as the sensor gave them. */
static void test_temps_content(void **state)
{
    static const int16_t temps[AACMM_JOINTS_MAX] = {2150, -1234, 8600, 777, 0, -4000, 3000};
    aacmm_msg_t m;
    int i;
    (void)state;
    memcpy(F.temp, temps, sizeof F.temp);
    F.temp_valid = (uint8_t)(0x7Fu & ~(1u << 3)); /* link 4 does not answer */
    F.counts[2] = 0x30000000u;
    measure(AACMM_CONTENT_TEMPERATURES, 1);
    assert_int_equal(M.u.sample.content, AACMM_CONTENT_TEMPERATURES);
    assert_int_equal(M.u.sample.status, AACMM_SAMPLE_POINT_VALID | AACMM_SAMPLE_PARAMS_DEFAULT |
                                            AACMM_SAMPLE_TEMP_FAULT);
    for (i = 0; i < 6; i++) {
        assert_int_equal(M.u.sample.temp[i], i == 3 ? AACMM_TEMP_NONE : temps[i]);
    }
    /* both contents: the temperatures and the Jacobian */
    {
        aacmm_msg_t with_jac;
        measure(AACMM_CONTENT_TEMPERATURES | AACMM_CONTENT_JACOBIAN, 2);
        with_jac = M;
        measure(AACMM_CONTENT_JACOBIAN, 3);
        assert_memory_equal(with_jac.u.sample.jacobian, M.u.sample.jacobian,
                            sizeof M.u.sample.jacobian);
        assert_memory_equal(with_jac.u.sample.point_100nm, M.u.sample.point_100nm,
                            sizeof M.u.sample.point_100nm);
        assert_memory_equal(with_jac.u.sample.temp, temps, 3 * sizeof(int16_t));
    }
    /* DIAG over the wire: the three samples so far */
    send_simple(AACMM_MSG_DIAG_REQ, 4);
    expect_response(AACMM_MSG_DIAG_RSP, 4);
    assert_int_equal(M.u.diag.temp_faults, 3u);
    /* a serial stream with temperatures; a trigger event during it carries them */
    fake_use_temperatures(&F, &PF);
    F.temp[0] = 2555;
    memset(&m, 0, sizeof m);
    start_stream(100, AACMM_CONTENT_TEMPERATURES);
    assert_true(next_msg());
    assert_int_equal(M.type, AACMM_MSG_SAMPLE_EVT);
    assert_int_equal(M.u.sample.content, AACMM_CONTENT_TEMPERATURES);
    assert_int_equal(M.u.sample.temp[0], 2555);
    assert_int_equal(M.u.sample.temp[5], 2000);
    assert_int_equal(M.u.sample.status & AACMM_SAMPLE_TEMP_FAULT, 0u);
    F.button = 1u;
    aacmm_device_poll(&D);
    {
        int seen = 0;
        while (next_msg()) {
            if (M.type == AACMM_MSG_TRIGGER_EVT) {
                assert_int_equal(M.u.trigger.sample.content, AACMM_CONTENT_TEMPERATURES);
                assert_int_equal(M.u.trigger.sample.temp[0], 2555);
                seen = 1;
            }
        }
        assert_true(seen);
    }
    send_simple(AACMM_MSG_DIAG_REQ, 5);
    aacmm_device_poll(&D);
    while (next_msg() && M.type != AACMM_MSG_DIAG_RSP) {
    }
    assert_int_equal(M.type, AACMM_MSG_DIAG_RSP);
    assert_int_equal(M.u.diag.temp_faults, 3u); /* all good since */
}

/* The paper's arm without its last joint: a valid set of 5 joints. */
static void five_joint_set(aacmm_param_set_t *s)
{
    default_set(s);
    s->arm.shape.joints = 5u;
    s->arm.shape.convention[5] = s->arm.shape.beta[5] = 0u;
    s->arm.theta_offset_rad[5] = s->arm.alpha_rad[5] = s->arm.d_mm[5] = s->arm.a_mm[5] = 0.0;
    s->arm.beta_rad[5] = 0.0;
    assert_int_equal(aacmm_arm_encoders_default(&s->enc, 5), AACMM_OK);
}

/* A port that serves exactly K joints (a simulator replaying a K-joint
 * file): SET_PARAMS of another joint count and RESTORE_DEFAULTS to such
 * defaults are refused, the set in force unchanged; K itself is taken. */
static void test_joints_exact(void **state)
{
    aacmm_param_set_t five;
    aacmm_param_set_t six;
    aacmm_param_set_t other;
    uint32_t six_crc;
    (void)state;
    five_joint_set(&five);
    default_set(&six);
    six_crc = set_crc(&six);
    /* K outside 4 .. 7: a configuration error */
    setup_links(1, 0, 0, 0, 0);
    CFG.joints_exact = 3u;
    assert_int_equal(aacmm_device_init(&D, &CFG, &PF), AACMM_ERR_RANGE);
    CFG.joints_exact = (uint8_t)(AACMM_JOINTS_MAX + 1);
    assert_int_equal(aacmm_device_init(&D, &CFG, &PF), AACMM_ERR_RANGE);
    /* K = 6 with the paper's six-joint defaults */
    CFG.joints_exact = 6u;
    boot();
    send_set_params(&five, 1);
    expect_error(AACMM_ERR_UNSUPPORTED, AACMM_MSG_SET_PARAMS_REQ, 1);
    send_simple(AACMM_MSG_INFO_REQ, 2);
    expect_response(AACMM_MSG_INFO_RSP, 2);
    assert_int_equal(M.u.info.param_crc32, six_crc); /* six joints, unchanged */
    other_set(&other, 101.0); /* six joints: taken */
    set_params(&other, 3);
    /* K = 5 on a device whose defaults have six: the port started it on a
     * five-joint set; going back to the defaults is refused */
    setup_links(1, 0, 0, 0, 0);
    CFG.joints_exact = 5u;
    boot();
    set_params(&five, 4);
    assert_int_equal(M.u.param_crc.param_crc32, set_crc(&five));
    send_simple(AACMM_MSG_RESTORE_DEFAULTS_REQ, 5);
    expect_error(AACMM_ERR_UNSUPPORTED, AACMM_MSG_RESTORE_DEFAULTS_REQ, 5);
    send_simple(AACMM_MSG_INFO_REQ, 6);
    expect_response(AACMM_MSG_INFO_RSP, 6);
    assert_int_equal(M.u.info.joints, 5);
    /* 0: any joint count, as before */
    setup_links(1, 0, 0, 0, 0);
    boot();
    set_params(&five, 7);
    send_simple(AACMM_MSG_RESTORE_DEFAULTS_REQ, 8);
    expect_response(AACMM_MSG_RESTORE_DEFAULTS_RSP, 8);
}

/* Press button 1 (from released) and take the TRIGGER_EVT it sends into M. */
static void press_for_trigger(void)
{
    F.button = 0u;
    advance(1000u);
    aacmm_device_poll(&D);
    F.button = 1u;
    advance(1000u);
    aacmm_device_poll(&D);
    assert_true(next_msg());
    assert_int_equal(M.type, AACMM_MSG_TRIGGER_EVT);
}

/* A button edge with no stream running: the trigger sample carries the link
 * temperatures on a device that reads them (a point taken before the stream
 * starts is still a measurement), none on a device without sensors. */
static void test_temps_trigger_without_stream(void **state)
{
    (void)state;
    fake_use_temperatures(&F, &PF);
    F.temp[1] = 2345;
    aacmm_device_poll(&D);
    press_for_trigger();
    assert_int_equal(M.u.trigger.sample.seq, 0u);
    assert_int_equal(M.u.trigger.sample.content, AACMM_CONTENT_TEMPERATURES);
    assert_int_equal(M.u.trigger.sample.temp[0], 2000);
    assert_int_equal(M.u.trigger.sample.temp[1], 2345);
    assert_int_equal(M.u.trigger.sample.status & AACMM_SAMPLE_TEMP_FAULT, 0u);
    /* the same device without sensors: no temperatures */
    setup_links(1, 1, 1, 1, 0);
    boot();
    aacmm_device_poll(&D);
    while (next_msg()) {
    }
    press_for_trigger();
    assert_int_equal(M.u.trigger.sample.content, 0u);
}

/* A CAN stream with temperatures goes as SAMPLE_EVT over ISO-TP (the sample
 * frames carry no temperatures). */
static void test_temps_can_stream_over_isotp(void **state)
{
    aacmm_msg_t m;
    uint32_t n = 0;
    int rounds = 0;
    size_t i;
    (void)state;
    F.temp[2] = -999;
    host_isotp_init(3);
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_STREAM_START_REQ;
    m.seq = 8;
    m.u.stream.rate_hz = 50;
    m.u.stream.content = AACMM_CONTENT_TEMPERATURES;
    can_request(&m);
    assert_true(can_exchange(5));
    assert_int_equal(M.type, AACMM_MSG_STREAM_START_RSP);
    assert_int_equal(M.u.stream.content, AACMM_CONTENT_TEMPERATURES);
    while (n < 5u && rounds < 1000) {
        advance(1000);
        if (can_exchange(50)) {
            assert_int_equal(M.type, AACMM_MSG_SAMPLE_EVT);
            assert_int_equal(M.u.sample.content, AACMM_CONTENT_TEMPERATURES);
            assert_int_equal(M.u.sample.temp[2], -999);
            assert_int_equal(M.u.sample.seq, n);
            n++;
        }
        rounds++;
    }
    assert_int_equal(n, 5u);
    for (i = 0; i < F.can_tx_len; i++) {
        assert_int_not_equal(F.can_tx[i].id, AACMM_CAN_ID_SAMPLE_HEADER + 3u);
    }
}

/* Without sensors the TEMPERATURES content is refused; COMPUTE with
 * temperatures works on any device (without the thermal block: the point of
 * COMPUTE without them, bit for bit). Both contents on N 7, P 37 do not fit
 * a body: ERR_RANGE. */
static void test_temps_content_refused(void **state)
{
    aacmm_msg_t m;
    aacmm_msg_t plain;
    aacmm_param_set_t set;
    int i;
    (void)state;
    measure(AACMM_CONTENT_JACOBIAN, 1); /* a device without sensors (setup_default) */
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_MEASURE_REQ;
    m.seq = 2;
    m.u.measure.content = AACMM_CONTENT_TEMPERATURES;
    send_msg(&m);
    expect_error(AACMM_ERR_UNSUPPORTED, AACMM_MSG_MEASURE_REQ, 2);
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_STREAM_START_REQ;
    m.seq = 3;
    m.u.stream.rate_hz = 100;
    m.u.stream.content = AACMM_CONTENT_TEMPERATURES | AACMM_CONTENT_JACOBIAN;
    send_msg(&m);
    expect_error(AACMM_ERR_UNSUPPORTED, AACMM_MSG_STREAM_START_REQ, 3);
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_COMPUTE_REQ;
    m.seq = 4;
    m.u.compute_req.content = AACMM_CONTENT_JACOBIAN;
    m.u.compute_req.joints = 6;
    m.u.compute_req.counts[0] = 0x12345678u;
    m.u.compute_req.counts[4] = 0x9ABCDEF0u;
    send_msg(&m);
    expect_response(AACMM_MSG_COMPUTE_RSP, 4);
    plain = M;
    m.seq = 5;
    m.u.compute_req.content = AACMM_CONTENT_JACOBIAN | AACMM_CONTENT_TEMPERATURES;
    for (i = 0; i < 6; i++) {
        m.u.compute_req.temp[i] = (int16_t)(4500 + 100 * i);
    }
    send_msg(&m);
    expect_response(AACMM_MSG_COMPUTE_RSP, 5);
    assert_int_equal(M.u.compute_rsp.content, AACMM_CONTENT_JACOBIAN | AACMM_CONTENT_TEMPERATURES);
    assert_memory_equal(M.u.compute_rsp.point_mm, plain.u.compute_rsp.point_mm,
                        sizeof plain.u.compute_rsp.point_mm);
    assert_memory_equal(M.u.compute_rsp.jacobian, plain.u.compute_rsp.jacobian,
                        sizeof plain.u.compute_rsp.jacobian);
    /* N 7, P 37 (six betas, a tip vector) on a device with sensors */
    setup_links(1, 1, 1, 1, 0);
    fake_use_temperatures(&F, &PF);
    boot();
    memset(&set, 0, sizeof set);
    set.arm.shape.joints = 7u;
    set.arm.shape.tip = (uint8_t)AACMM_TIP_XYZ;
    for (i = 0; i < 7; i++) {
        set.arm.alpha_rad[i] = (i % 2 == 0) ? 1.5707963267948966 : -1.5707963267948966;
        set.arm.d_mm[i] = 100.0 + 50.0 * i;
        if (i > 0) {
            set.arm.shape.beta[i] = 1u;
            set.arm.beta_rad[i] = 0.001 * i;
        }
    }
    set.arm.tip_mm[2] = 110.0;
    assert_int_equal(aacmm_arm_encoders_default(&set.enc, 7), AACMM_OK);
    assert_int_equal(aacmm_shape_params(&set.arm.shape), 37);
    set_params(&set, 6);
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_MEASURE_REQ;
    m.seq = 7;
    m.u.measure.content = AACMM_CONTENT_TEMPERATURES | AACMM_CONTENT_JACOBIAN;
    send_msg(&m);
    expect_error(AACMM_ERR_RANGE, AACMM_MSG_MEASURE_REQ, 7);
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_STREAM_START_REQ;
    m.seq = 8;
    m.u.stream.rate_hz = 100;
    m.u.stream.content = AACMM_CONTENT_TEMPERATURES | AACMM_CONTENT_JACOBIAN;
    send_msg(&m);
    expect_error(AACMM_ERR_RANGE, AACMM_MSG_STREAM_START_REQ, 8);
    measure(AACMM_CONTENT_TEMPERATURES, 9); /* each alone fits */
    assert_int_equal(M.u.sample.temp[6], 2000);
    measure(AACMM_CONTENT_JACOBIAN, 10);
    assert_int_equal(M.u.sample.params, 37);
}

/* COMPUTE at the request's temperatures with the thermal block: the core's
 * point and Jacobian there; the next sample is at the sensors' again. */
static void test_temps_compute_thermal(void **state)
{
    static const int16_t req[AACMM_JOINTS_MAX] = {-2550, 6000, 2001, 4444, -1, 8500, 0};
    static const uint32_t counts[AACMM_JOINTS] = {0x76543210u, 0x10000000u, 0xC0000000u,
                                                  0x0F0F0F0Fu, 0x55555555u, 0xAAAAAAAAu};
    aacmm_param_set_t set;
    aacmm_msg_t m;
    double want[3];
    float jac[AACMM_JAC_SIZE_MAX];
    int np;
    (void)state;
    thermal_set(&set, 1850);
    np = aacmm_shape_params(&set.arm.shape);
    set_params(&set, 1);
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_COMPUTE_REQ;
    m.seq = 2;
    m.u.compute_req.content = AACMM_CONTENT_JACOBIAN | AACMM_CONTENT_TEMPERATURES;
    m.u.compute_req.joints = 6;
    memcpy(m.u.compute_req.counts, counts, sizeof counts);
    memcpy(m.u.compute_req.temp, req, sizeof req);
    send_msg(&m);
    expect_response(AACMM_MSG_COMPUTE_RSP, 2);
    core_point_at(&set, counts, req, want, jac);
    assert_int_equal(M.u.compute_rsp.content, AACMM_CONTENT_JACOBIAN | AACMM_CONTENT_TEMPERATURES);
    assert_int_equal(M.u.compute_rsp.status, AACMM_SAMPLE_POINT_VALID);
    assert_memory_equal(M.u.compute_rsp.point_mm, want, sizeof want);
    assert_memory_equal(M.u.compute_rsp.jacobian, jac, (size_t)(3 * np) * sizeof(float));
    /* the point only */
    m.seq = 3;
    m.u.compute_req.content = AACMM_CONTENT_TEMPERATURES;
    send_msg(&m);
    expect_response(AACMM_MSG_COMPUTE_RSP, 3);
    assert_memory_equal(M.u.compute_rsp.point_mm, want, sizeof want);
    /* a sample afterwards: at the sensors' 20.00 degC, not the request's */
    memcpy(F.counts, counts, sizeof counts);
    F.temp[3] = 3300;
    core_point_at(&set, counts, F.temp, want, jac);
    measure(AACMM_CONTENT_TEMPERATURES | AACMM_CONTENT_JACOBIAN, 4);
    assert_wire_point(M.u.sample.point_100nm, want);
    assert_memory_equal(M.u.sample.jacobian, jac, (size_t)(3 * np) * sizeof(float));
    assert_int_equal(M.u.sample.temp[3], 3300);
}

#ifdef AACMM_DEVICE_KIN_FIXED
#include "device_kin.h"

/* The fixed path's temperature: 0.01 degC to Q8 exactly, half away from
 * zero, for every i16 (against the core's aacmm_temp_q8_from_f64 in range,
 * and libm's round beyond). */
static void test_temps_q8_rounding(void **state)
{
    int32_t t;
    (void)state;
    for (t = INT16_MIN; t <= INT16_MAX; t++) {
        int32_t got = aacmm_device_temp_q8((int16_t)t);
        double c = (double)t / 100.0;
        if (t >= AACMM_REF_TEMP_MIN && t <= AACMM_REF_TEMP_MAX) {
            int32_t want = 0;
            assert_int_equal(aacmm_temp_q8_from_f64(&want, &c, 1u), AACMM_OK);
            assert_int_equal(got, want);
        }
        assert_int_equal(got, (int32_t)round((double)t * 2.56));
    }
}
#endif

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_init_errors),
        cmocka_unit_test_setup(test_ping_info, setup_default),
        cmocka_unit_test_setup(test_params_set_get_restore, setup_default),
        cmocka_unit_test_setup(test_seven_joint_arm_model, setup_default),
        cmocka_unit_test_setup(test_measure_and_compute, setup_default),
        cmocka_unit_test_setup(test_error_model_applied, setup_default),
        cmocka_unit_test_setup(test_error_model_seven_axes, setup_default),
        cmocka_unit_test_setup(test_stream_start_stop, setup_default),
        cmocka_unit_test_setup(test_bad_requests, setup_default),
        cmocka_unit_test_setup(test_garbage_and_crc_errors, setup_default),
        cmocka_unit_test(test_storage_unsupported),
        cmocka_unit_test_setup(test_stream_1khz_cadence, setup_default),
        cmocka_unit_test_setup(test_stream_odd_rate_and_jitter, setup_default),
        cmocka_unit_test_setup(test_stream_catch_up_and_stall, setup_default),
        cmocka_unit_test_setup(test_stream_output_full, setup_default),
        cmocka_unit_test_setup(test_response_not_behind_queued_samples, setup_default),
        cmocka_unit_test_setup(test_stale_samples_dropped, setup_default),
        cmocka_unit_test_setup(test_save_and_reload, setup_default),
        cmocka_unit_test(test_store_alternates_slots),
        cmocka_unit_test(test_power_cut_at_every_byte),
        cmocka_unit_test_setup(test_power_cut_via_request, setup_default),
        cmocka_unit_test(test_corrupt_and_foreign_records),
        cmocka_unit_test(test_store_report_says_what_was_found),
        cmocka_unit_test(test_param_source_three_states),
        cmocka_unit_test(test_diag_request),
        cmocka_unit_test(test_store_generation_wraps),
        cmocka_unit_test_setup(test_button_events, setup_default),
        cmocka_unit_test_setup(test_button_during_stream, setup_default),
        cmocka_unit_test_setup(test_two_buttons, setup_default),
        cmocka_unit_test_setup(test_button_held_at_boot, setup_default),
        cmocka_unit_test_setup(test_stream_info, setup_default),
        cmocka_unit_test_setup(test_can_requests, setup_default),
        cmocka_unit_test_setup(test_can_stream_and_both_links, setup_default),
        cmocka_unit_test_setup(test_can_jacobian_stream_over_isotp, setup_default),
        cmocka_unit_test_setup(test_encoder_io_fault, setup_default),
        cmocka_unit_test_setup(test_serial_io_errors_counted, setup_default),
        cmocka_unit_test(test_enc_frames_round_trip),
        cmocka_unit_test(test_enc_frames_faults),
        cmocka_unit_test(test_device_decodes_frames),
        cmocka_unit_test(test_power_cut_flash_erase_and_write),
        cmocka_unit_test(test_sim_init_errors),
        cmocka_unit_test(test_sim_static_repeatable),
        cmocka_unit_test(test_sim_angle_to_counts),
        cmocka_unit_test(test_sim_sweep_and_walk_smooth),
        cmocka_unit_test(test_sim_walk_seeded),
        cmocka_unit_test(test_sim_noise_bounds),
        cmocka_unit_test(test_sim_replay_loops),
        cmocka_unit_test(test_sim_replay_joints),
        cmocka_unit_test(test_sim_button),
        cmocka_unit_test(test_sim_drives_device),
        cmocka_unit_test_setup(test_temps_info_flag, setup_temps),
        cmocka_unit_test_setup(test_temps_thermal_point, setup_temps),
        cmocka_unit_test_setup(test_temps_fault_thermal, setup_temps),
        cmocka_unit_test_setup(test_temps_fault_plain, setup_default),
        cmocka_unit_test(test_temps_bytes_unchanged),
        cmocka_unit_test_setup(test_temps_stored_thermal_set, setup_temps),
        cmocka_unit_test_setup(test_temps_content, setup_temps),
        cmocka_unit_test_setup(test_temps_trigger_without_stream, setup_temps),
        cmocka_unit_test(test_joints_exact),
        cmocka_unit_test_setup(test_temps_can_stream_over_isotp, setup_temps),
        cmocka_unit_test_setup(test_temps_content_refused, setup_default),
        cmocka_unit_test_setup(test_temps_compute_thermal, setup_temps),
#ifdef AACMM_DEVICE_KIN_FIXED
        cmocka_unit_test(test_temps_q8_rounding),
#endif
    };
    return cmocka_run_group_tests_name("device", tests, NULL, NULL);
}
