/*
 * CMocka suite of the link-protocol C codec: CRC, COBS, serial framing and
 * resynchronisation, message codec against the shared vectors, CAN sample
 * frames, ISO-TP (against the can-isotp segmentations in the vectors, in
 * loopback, and every error path).
 */
#define _POSIX_C_SOURCE 200809L
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "aacmm/cobs.h"
#include "aacmm/crc32.h"
#include "aacmm/frame.h"
#include "aacmm/isotp.h"
#include "aacmm/proto.h"
#include "aacmm/proto_can.h"
#include "vectors.h"

#ifndef VECTORS_PATH
#define VECTORS_PATH "tests/vectors/protocol_vectors.txt"
#endif

static vec_record_t g_vec[VEC_MAX_RECORDS];
static size_t g_nvec;

static size_t count_kind(const char *kind)
{
    size_t i, n = 0;
    for (i = 0; i < g_nvec; i++) {
        n += strcmp(g_vec[i].kind, kind) == 0;
    }
    return n;
}

/* ---------------------------------------------------------------- CRC */

static void test_crc32_check_value(void **state)
{
    const uint8_t check[] = "123456789";
    uint32_t run;
    size_t i;
    (void)state;
    assert_int_equal(aacmm_crc32(check, 9), AACMM_CRC32_CHECK);
    assert_int_equal(aacmm_crc32(check, 9), 0xCBF43926u);
    assert_int_equal(aacmm_crc32(NULL, 0), 0u);
    run = AACMM_CRC32_INIT;
    for (i = 0; i < 9; i++) {
        run = aacmm_crc32_update(run, &check[i], 1);
    }
    assert_int_equal(aacmm_crc32_final(run), 0xCBF43926u);
    for (i = 0; i < g_nvec; i++) {
        const vec_record_t *r = &g_vec[i];
        uint32_t want;
        if (strcmp(r->kind, "crc") != 0) {
            continue;
        }
        assert_int_equal(r->b_len, 4);
        want = ((uint32_t)r->b[0] << 24) | ((uint32_t)r->b[1] << 16) | ((uint32_t)r->b[2] << 8) |
               r->b[3];
        assert_int_equal(aacmm_crc32(r->a, r->a_len), want);
    }
}

/* ---------------------------------------------------------------- COBS */

static void test_cobs_known_encodings(void **state)
{
    uint8_t in[600], enc[700], dec[700];
    size_t n = 0, m = 0, len;
    const uint8_t zero = 0;
    (void)state;
    assert_int_equal(aacmm_cobs_encode(NULL, 0, enc, sizeof enc, &n), AACMM_OK);
    assert_int_equal(n, 1);
    assert_int_equal(enc[0], 1);
    assert_int_equal(aacmm_cobs_encode(&zero, 1, enc, sizeof enc, &n), AACMM_OK);
    assert_int_equal(n, 2);
    assert_int_equal(enc[0], 1);
    assert_int_equal(enc[1], 1);
    memset(in, 0x11, sizeof in);
    /* 254 non-zero bytes: one full piece, no trailing code byte */
    assert_int_equal(aacmm_cobs_encode(in, 254, enc, sizeof enc, &n), AACMM_OK);
    assert_int_equal(n, 255);
    assert_int_equal(enc[0], 0xFF);
    /* 255 bytes: full piece then a piece of one */
    assert_int_equal(aacmm_cobs_encode(in, 255, enc, sizeof enc, &n), AACMM_OK);
    assert_int_equal(n, 257);
    assert_int_equal(enc[255], 2);
    /* 254 bytes then a zero */
    in[254] = 0;
    assert_int_equal(aacmm_cobs_encode(in, 255, enc, sizeof enc, &n), AACMM_OK);
    assert_int_equal(n, 257);
    assert_int_equal(enc[255], 1);
    assert_int_equal(enc[256], 1);
    /* round trip over many lengths and patterns, within the size bound */
    for (len = 0; len <= sizeof in; len++) {
        size_t i;
        for (i = 0; i < len; i++) {
            in[i] = (uint8_t)((i * 37u + len) % 7u == 0u ? 0u : (i * 13u + 1u));
        }
        assert_int_equal(aacmm_cobs_encode(in, len, enc, sizeof enc, &n), AACMM_OK);
        assert_true(n <= AACMM_COBS_MAX_ENCODED(len));
        assert_null(memchr(enc, 0, n));
        assert_int_equal(aacmm_cobs_decode(enc, n, dec, sizeof dec, &m), AACMM_OK);
        assert_int_equal(m, len);
        assert_memory_equal(dec, in, len);
    }
}

static void test_cobs_rejects(void **state)
{
    uint8_t out[16], in[300], enc[400];
    size_t n = 99, cap, len;
    const uint8_t runs_past[] = {0x05, 0x01, 0x02};
    const uint8_t has_zero[] = {0x03, 0x00, 0x02};
    const uint8_t ok[] = {0x03, 0x41, 0x42, 0x01};
    (void)state;
    assert_int_equal(aacmm_cobs_decode(runs_past, sizeof runs_past, out, sizeof out, &n),
                     AACMM_ERR_FRAME);
    assert_int_equal(n, 0);
    assert_int_equal(aacmm_cobs_decode(has_zero, sizeof has_zero, out, sizeof out, &n),
                     AACMM_ERR_FRAME);
    assert_int_equal(aacmm_cobs_decode(ok, 0, out, sizeof out, &n), AACMM_ERR_FRAME);
    assert_int_equal(aacmm_cobs_decode(ok, sizeof ok, out, 2, &n), AACMM_ERR_BUFFER);
    assert_int_equal(aacmm_cobs_decode(ok, sizeof ok, out, 3, &n), AACMM_OK);
    assert_int_equal(n, 3);
    assert_int_equal(aacmm_cobs_decode(NULL, 1, out, 3, &n), AACMM_ERR_NULL);
    /* the encoder never writes past a short buffer (ASan would catch it) */
    memset(in, 0x5A, sizeof in);
    in[100] = 0;
    for (len = 0; len <= sizeof in; len += 50) {
        size_t need;
        assert_int_equal(aacmm_cobs_encode(in, len, enc, sizeof enc, &need), AACMM_OK);
        for (cap = 1; cap < need; cap++) {
            uint8_t *tight = enc + sizeof enc - cap; /* buffer ends exactly at enc's end */
            assert_int_equal(aacmm_cobs_encode(in, len, tight, cap, &n), AACMM_ERR_BUFFER);
            assert_int_equal(n, 0);
        }
    }
}

/* ---------------------------------------------------------------- messages */

static void test_vectors_encode_decode(void **state)
{
    size_t i, checked = 0;
    (void)state;
    for (i = 0; i < g_nvec; i++) {
        const vec_record_t *r = &g_vec[i];
        aacmm_msg_t want, got;
        uint8_t body[AACMM_PROTO_MAX_BODY], wire[AACMM_FRAME_MAX_WIRE], scratch[AACMM_PROTO_MAX_BODY];
        size_t n = 0;
        if (strcmp(r->kind, "msg") != 0) {
            continue;
        }
        if (!vec_expected_msg(r->name, &want)) {
            fail_msg("vector %s has no C expectation", r->name);
        }
        /* C values -> bytes of the file */
        assert_int_equal(aacmm_msg_encode(&want, body, sizeof body, &n), AACMM_OK);
        assert_int_equal(n, r->a_len);
        assert_memory_equal(body, r->a, n);
        assert_int_equal(aacmm_frame_encode(body, n, wire, sizeof wire, &n), AACMM_OK);
        assert_int_equal(n, r->b_len);
        assert_memory_equal(wire, r->b, n);
        assert_int_equal(aacmm_msg_encode_frame(&want, scratch, sizeof scratch, wire, sizeof wire, &n),
                         AACMM_OK);
        assert_memory_equal(wire, r->b, n);
        /* bytes of the file -> C values */
        memset(&got, 0xA5, sizeof got);
        assert_int_equal(aacmm_msg_decode(r->a, r->a_len, &got), AACMM_OK);
        if (!vec_msg_equal(&got, &want)) {
            fail_msg("vector %s decodes to other values", r->name);
        }
        checked++;
    }
    assert_int_equal(checked, 40);
}

static void test_vectors_bad_bodies(void **state)
{
    size_t i, checked = 0;
    (void)state;
    for (i = 0; i < g_nvec; i++) {
        const vec_record_t *r = &g_vec[i];
        aacmm_status_t want;
        aacmm_msg_t got;
        aacmm_status_t st;
        if (strcmp(r->kind, "badbody") != 0) {
            continue;
        }
        assert_true(vec_status_from_name(r->word, &want));
        st = aacmm_msg_decode(r->a, r->a_len, &got);
        if (st != want) {
            fail_msg("bad body %s: got %d want %d", r->name, (int)st, (int)want);
        }
        checked++;
    }
    assert_true(checked >= 30);
}

static void test_truncated_and_extended(void **state)
{
    size_t i;
    (void)state;
    for (i = 0; i < g_nvec; i++) {
        const vec_record_t *r = &g_vec[i];
        uint8_t longer[VEC_MAX_BYTES + 1];
        aacmm_msg_t got;
        size_t len;
        if (strcmp(r->kind, "msg") != 0) {
            continue;
        }
        for (len = 0; len < r->a_len; len++) {
            /* copy to an exact-size heap-free stack buffer end so ASan sees over-reads */
            uint8_t *tail = longer + sizeof longer - len;
            memcpy(tail, r->a, len);
            assert_int_equal(aacmm_msg_decode(tail, len, &got), AACMM_ERR_LENGTH);
        }
        memcpy(longer, r->a, r->a_len);
        longer[r->a_len] = 0;
        assert_int_equal(aacmm_msg_decode(longer, r->a_len + 1, &got), AACMM_ERR_LENGTH);
    }
}

static void test_unknown_types_and_version(void **state)
{
    unsigned t;
    uint8_t body[8] = {AACMM_PROTO_VERSION, 0, 0, 0, 0, 0, 0, 0};
    aacmm_msg_t m;
    unsigned v;
    (void)state;
    for (t = 0; t < 256; t++) {
        aacmm_status_t st;
        body[1] = (uint8_t)t;
        body[2] = 0x77;
        st = aacmm_msg_decode(body, 3, &m);
        if (aacmm_msg_type_known((uint8_t)t)) {
            assert_true(st == AACMM_OK || st == AACMM_ERR_LENGTH);
        } else {
            assert_int_equal(st, AACMM_ERR_UNKNOWN_TYPE);
        }
        assert_int_equal(m.type, t); /* header is reported for the error response */
        assert_int_equal(m.seq, 0x77);
    }
    /* 1: six joints; 2: the arm model before the error model's layout; 3:
     * the error model before device temperatures; 5: a future version. Type
     * and seq are still reported (for the error response). */
    assert_int_equal(AACMM_PROTO_VERSION, 4);
    assert_int_equal(AACMM_PROTO_VERSION_PREVIOUS, 3);
    assert_int_equal(AACMM_PROTO_VERSION_OLDEST, 1);
    body[1] = AACMM_MSG_INFO_REQ;
    for (v = 0; v <= AACMM_PROTO_VERSION + 1u; v++) {
        if (v == AACMM_PROTO_VERSION) {
            continue;
        }
        body[0] = (uint8_t)v;
        m.type = 0;
        m.seq = 0;
        assert_int_equal(aacmm_msg_decode(body, 3, &m), AACMM_ERR_VERSION);
        assert_int_equal(m.type, AACMM_MSG_INFO_REQ);
        assert_int_equal(m.seq, 0x77);
    }
    assert_int_equal(aacmm_msg_decode(NULL, 3, &m), AACMM_ERR_NULL);
    assert_int_equal(aacmm_msg_decode(body, 3, NULL), AACMM_ERR_NULL);
}

/* The parameter set's encoder rule at every boundary, both ways: the wire
 * layout (docs/protocol.md 2.3, the paper's arm: header 8 bytes, 25 f64,
 * then u32 cpr - 1 [6], u32 zero[6], i8 direction[6]) patched on a valid
 * encoding for the decoder (where the wire can hold the value: cpr 1 ..
 * 2^32), the same values set in the struct for the encoder, and the same
 * verdict from aacmm_arm_encoders_validate (the one check both use). */
static void test_param_set_encoder_rule(void **state)
{
    static const struct {
        uint64_t cpr;
        uint32_t zero;
        uint8_t dir_byte;
        int ok;
    } cases[] = {
        {2u, 0u, 0x01u, 1},           {2u, 1u, 0xFFu, 1},
        {4294967296ull, 4294967295u, 0x01u, 1},
        {1u, 0u, 0x01u, 0},           {0u, 0u, 0x01u, 0},
        {4294967297ull, 0u, 0x01u, 0}, {UINT64_MAX, 0u, 0x01u, 0},
        {1000u, 999u, 0x01u, 1},      {1000u, 1000u, 0x01u, 0},
        {1000u, 4294967295u, 0x01u, 0}, {1000u, 0u, 0x00u, 0},
        {1000u, 0u, 0x02u, 0},        {1000u, 0u, 0xFEu, 0},
    };
    const size_t cpr_at = 208u, zero_at = 232u, dir_at = 256u;
    aacmm_msg_t m;
    aacmm_param_set_t valid, set, back;
    uint8_t wire[AACMM_PARAM_SET_PAPER_BYTES];
    uint8_t patched[AACMM_PARAM_SET_PAPER_BYTES];
    size_t c, j, k, len = 0;
    (void)state;
    assert_true(vec_expected_msg("set_params_req", &m));
    valid = m.u.params;
    assert_int_equal(aacmm_param_set_encode(&valid, wire, sizeof wire, &len), AACMM_OK);
    assert_int_equal(len, AACMM_PARAM_SET_PAPER_BYTES);
    assert_int_equal(AACMM_PARAM_SET_BYTES(6u, 25u, 0u, 0u), AACMM_PARAM_SET_PAPER_BYTES);
    assert_int_equal(AACMM_PARAM_SET_BYTES(7u, 37u, 28u, 1u), AACMM_PARAM_SET_MAX_BYTES);
    for (c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        const int on_wire = cases[c].cpr >= 1u && cases[c].cpr <= 4294967296ull;
        for (j = 0; j < AACMM_JOINTS; j++) {
            const aacmm_status_t want = cases[c].ok ? AACMM_OK : AACMM_ERR_RANGE;
            memcpy(patched, wire, sizeof wire);
            if (on_wire) {
                for (k = 0; k < 4u; k++) {
                    patched[cpr_at + 4u * j + k] = (uint8_t)((cases[c].cpr - 1u) >> (8u * k));
                }
                for (k = 0; k < 4u; k++) {
                    patched[zero_at + 4u * j + k] = (uint8_t)(cases[c].zero >> (8u * k));
                }
                patched[dir_at + j] = cases[c].dir_byte;
                assert_int_equal(aacmm_param_set_decode(patched, sizeof patched, &back), want);
            }

            set = valid;
            set.enc.counts_per_rev[j] = cases[c].cpr;
            set.enc.zero_offset_counts[j] = cases[c].zero;
            set.enc.direction[j] = (int8_t)cases[c].dir_byte;
            assert_int_equal(aacmm_arm_encoders_validate(&set.enc), want);
            assert_int_equal(aacmm_param_set_encode(&set, wire, sizeof wire, &len), want);
            if (cases[c].ok) {
                assert_memory_equal(wire, patched, sizeof wire);
                assert_int_equal(back.enc.counts_per_rev[j], cases[c].cpr);
                assert_int_equal(back.enc.zero_offset_counts[j], cases[c].zero);
                assert_int_equal(back.enc.direction[j], set.enc.direction[j]);
            }
            assert_int_equal(aacmm_param_set_encode(&valid, wire, sizeof wire, &len), AACMM_OK);
        }
    }
}

/* What the parameter set layout does not carry must be 0 (canonical
 * encoding), and the shape rules of the header. */
static void test_param_set_shape_rules(void **state)
{
    aacmm_msg_t m;
    aacmm_param_set_t p;
    uint8_t buf[AACMM_PARAM_SET_MAX_BYTES];
    size_t len = 0;
    (void)state;
    assert_true(vec_expected_msg("get_params_rsp7", &m));
    p = m.u.params;
    assert_int_equal(aacmm_param_set_encode(&p, buf, sizeof buf, &len), AACMM_OK);
    assert_int_equal(len, AACMM_PARAM_SET_BYTES(7u, 33u, 0u, 0u));
    p.arm.beta_rad[1] = 0.5; /* joint 2 declares no beta */
    assert_int_equal(aacmm_param_set_encode(&p, buf, sizeof buf, &len), AACMM_ERR_RANGE);
    assert_int_equal(len, 0);
    p = m.u.params;
    p.arm.shape.beta[0] = 1u; /* joint 1 */
    assert_int_equal(aacmm_param_set_encode(&p, buf, sizeof buf, &len), AACMM_ERR_RANGE);
    p = m.u.params;
    p.enc.joints = 6u;
    assert_int_equal(aacmm_param_set_encode(&p, buf, sizeof buf, &len), AACMM_ERR_RANGE);
    p = m.u.params;
    p.arm.shape.tip = (uint8_t)AACMM_TIP_Z; /* t_x, t_y not carried */
    assert_int_equal(aacmm_param_set_encode(&p, buf, sizeof buf, &len), AACMM_ERR_RANGE);
    p = m.u.params;
    p.err.harm_cos[0][0] = 1; /* K = 0 */
    assert_int_equal(aacmm_param_set_encode(&p, buf, sizeof buf, &len), AACMM_ERR_RANGE);
    p = m.u.params;
    p.err.ref_temp = 1; /* no thermal block */
    assert_int_equal(aacmm_param_set_encode(&p, buf, sizeof buf, &len), AACMM_ERR_RANGE);
    p = m.u.params;
    p.err.harmonics[0] = 5u; /* K > 4 */
    assert_int_equal(aacmm_param_set_encode(&p, buf, sizeof buf, &len), AACMM_ERR_RANGE);
    assert_true(vec_expected_msg("set_params_req5e", &m));
    p = m.u.params;
    p.err.harmonics[5] = 1u; /* a K past N = 5 */
    assert_int_equal(aacmm_param_set_encode(&p, buf, sizeof buf, &len), AACMM_ERR_RANGE);
    p = m.u.params;
    p.err.ref_temp = 8501; /* above 85 degC */
    assert_int_equal(aacmm_param_set_encode(&p, buf, sizeof buf, &len), AACMM_ERR_RANGE);
    p.err.ref_temp = -4001; /* below -40 degC */
    assert_int_equal(aacmm_param_set_encode(&p, buf, sizeof buf, &len), AACMM_ERR_RANGE);
    p.err.ref_temp = -4000;
    assert_int_equal(aacmm_param_set_encode(&p, buf, sizeof buf, &len), AACMM_OK);
    p = m.u.params;
    p.err.harm_sin[1][1] = 3; /* past K = 1 */
    assert_int_equal(aacmm_param_set_encode(&p, buf, sizeof buf, &len), AACMM_ERR_RANGE);
    p = m.u.params;
    p.arm.d_mm[5] = 1.0; /* past N = 5 */
    assert_int_equal(aacmm_param_set_encode(&p, buf, sizeof buf, &len), AACMM_ERR_RANGE);
    p = m.u.params;
    assert_int_equal(aacmm_param_set_encode(&p, buf, sizeof buf, &len), AACMM_OK);
    assert_int_equal(len, AACMM_PARAM_SET_BYTES(5u, 23u, 8u, 1u));
    assert_int_equal(aacmm_param_set_encode(&p, buf, len - 1u, &len), AACMM_ERR_BUFFER);
}

static void test_helpers_counted_decode_error_reply(void **state)
{
    aacmm_msg_stats_t stats;
    aacmm_msg_t m, e;
    uint8_t out[16];
    size_t i, n = 0, bad = 0;
    unsigned t;
    (void)state;
    memset(&stats, 0, sizeof stats);
    for (i = 0; i < g_nvec; i++) {
        if (strcmp(g_vec[i].kind, "badbody") == 0) {
            assert_int_not_equal(aacmm_msg_decode_counted(g_vec[i].a, g_vec[i].a_len, &m, &stats),
                                 AACMM_OK);
            bad++;
        } else if (strcmp(g_vec[i].kind, "msg") == 0) {
            assert_int_equal(aacmm_msg_decode_counted(g_vec[i].a, g_vec[i].a_len, &m, NULL), AACMM_OK);
            assert_int_equal(aacmm_msg_decode_counted(g_vec[i].a, g_vec[i].a_len, &m, &stats), AACMM_OK);
        }
    }
    assert_int_equal(stats.ok, 40);
    assert_int_equal(stats.length + stats.version + stats.unknown_type + stats.range +
                         stats.not_finite, bad);
    assert_int_equal(stats.version, 5); /* versions 0, 1, 2, 3 and 5 */
    assert_int_equal(stats.unknown_type, 3);
    assert_int_equal(stats.other, 0);
    for (t = 0; t < 256; t++) {
        uint8_t r = aacmm_msg_response_type((uint8_t)t);
        if (t >= 1 && t <= 0x0B) {
            assert_int_equal(r, t | 0x80u);
            assert_true(aacmm_msg_type_known(r));
        } else {
            assert_int_equal(r, 0);
        }
    }
    assert_int_equal(aacmm_msg_make_error(&e, 3, 0x04, AACMM_ERR_RANGE), AACMM_OK);
    assert_true(vec_expected_msg("error_rsp", &m));
    assert_true(vec_msg_equal(&e, &m));
    assert_int_equal(aacmm_msg_encode(&e, out, sizeof out, &n), AACMM_OK);
    assert_int_equal(aacmm_msg_make_error(&e, 3, 0x04, AACMM_OK), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_msg_make_error(NULL, 3, 0x04, AACMM_ERR_CRC), AACMM_ERR_NULL);
}

static void test_encode_rejects(void **state)
{
    aacmm_msg_t m;
    uint8_t out[AACMM_PROTO_MAX_BODY];
    size_t n = 7, cap, need;
    const uint64_t nan_bits = 0x7FF8000000000000ull;
    const uint64_t inf_bits = 0x7FF0000000000000ull;
    const uint32_t fnan = 0x7FC00000u;
    (void)state;
    assert_true(vec_expected_msg("set_params_req", &m));
    memcpy(&m.u.params.arm.d_mm[2], &nan_bits, sizeof nan_bits);
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_NOT_FINITE);
    assert_int_equal(n, 0);
    assert_true(vec_expected_msg("set_params_req", &m));
    memcpy(&m.u.params.arm.tip_mm[2], &inf_bits, sizeof inf_bits);
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_NOT_FINITE);
    assert_true(vec_expected_msg("set_params_req", &m));
    m.u.params.enc.direction[4] = 0;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    assert_true(vec_expected_msg("set_params_req", &m));
    m.u.params.enc.counts_per_rev[0] = 4294967297ull;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    assert_true(vec_expected_msg("measure_rsp", &m));
    memcpy(&m.u.sample.jacobian[70], &fnan, sizeof fnan);
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_NOT_FINITE);
    m.u.sample.content = 0; /* Jacobian not sent: its contents do not matter */
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_OK);
    m.u.sample.content = 0x80;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    assert_true(vec_expected_msg("stream_start_req", &m));
    m.u.stream.rate_hz = 0;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    assert_true(vec_expected_msg("error_rsp", &m));
    m.u.error.status = 0;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    m.type = 0x3F;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_UNKNOWN_TYPE);
    assert_true(vec_expected_msg("trigger_evt", &m));
    m.u.trigger.pressed = 2;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    assert_true(vec_expected_msg("info_rsp", &m));
    m.u.info.can_node_id = 16;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    assert_true(vec_expected_msg("info_rsp", &m));
    m.u.info.param_source = AACMM_PARAM_SOURCE_HOST;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_OK);
    m.u.info.param_source = AACMM_PARAM_SOURCE_MAX + 1u;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    assert_true(vec_expected_msg("info_rsp", &m));
    m.u.info.params = 33u; /* not a 6-joint shape's P */
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    assert_true(vec_expected_msg("sample_evt7", &m));
    m.u.sample.joints = 8u;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    assert_true(vec_expected_msg("compute_req5", &m));
    m.u.compute_req.joints = 3u;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    assert_true(vec_expected_msg("compute_rsp5", &m));
    m.u.compute_rsp.params = 38u;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    assert_true(vec_expected_msg("diag_rsp7", &m));
    m.u.diag.joints = 8u;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    assert_true(vec_expected_msg("diag_rsp", &m));
    m.u.diag.joint[5].bits = 33u;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    assert_true(vec_expected_msg("diag_rsp", &m));
    m.u.diag.storage_flags = 2u;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    assert_true(vec_expected_msg("diag_rsp", &m));
    m.u.diag.reset_cause = AACMM_RESET_CAUSE_MAX + 1u;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    /* every too-small buffer is refused without overrun */
    assert_true(vec_expected_msg("get_params_rsp", &m));
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &need), AACMM_OK);
    assert_int_equal(need, 3 + AACMM_PARAM_SET_PAPER_BYTES);
    for (cap = 0; cap < need; cap++) {
        assert_int_equal(aacmm_msg_encode(&m, out + sizeof out - cap, cap, &n), AACMM_ERR_BUFFER);
    }
    assert_int_equal(aacmm_msg_encode(NULL, out, sizeof out, &n), AACMM_ERR_NULL);
}

/* Version 4's device temperatures: the sizes, the layout written out here
 * byte by byte, and the encoder's refusals (the decoder's are bad-body
 * vectors). */
static void put_u32(uint8_t *b, uint32_t v)
{
    b[0] = (uint8_t)(v & 0xFFu);
    b[1] = (uint8_t)((v >> 8) & 0xFFu);
    b[2] = (uint8_t)((v >> 16) & 0xFFu);
    b[3] = (uint8_t)(v >> 24);
}

static void put_i16(uint8_t *b, int16_t v)
{
    uint16_t u = (uint16_t)v;
    b[0] = (uint8_t)(u & 0xFFu);
    b[1] = (uint8_t)(u >> 8);
}

static void test_temperatures(void **state)
{
    aacmm_msg_t m, got;
    uint8_t out[AACMM_PROTO_MAX_BODY], want[64];
    size_t n = 0, i;
    (void)state;
    /* sizes: 31 + 4N (+ 2N) (+ 12P); COMPUTE_REQ 2 + 4N (+ 2N); DIAG 64 + 11N */
    assert_int_equal(AACMM_SAMPLE_BYTES(6u, 25u, AACMM_CONTENT_TEMPERATURES), 31 + 24 + 12);
    assert_int_equal(AACMM_SAMPLE_BYTES(7u, 36u, 0x03u), 505);
    assert_int_equal(AACMM_SAMPLE_MAX_BYTES, 505);
    assert_int_equal(AACMM_SAMPLE_BYTES(7u, 37u, 0x01u), 503);
    assert_true(AACMM_SAMPLE_BYTES(7u, 37u, 0x03u) >
                AACMM_PROTO_MAX_BODY - AACMM_PROTO_HEADER_BYTES);
    assert_true(AACMM_TRIGGER_EXTRA_BYTES + AACMM_SAMPLE_MAX_BYTES <=
                AACMM_PROTO_MAX_BODY - AACMM_PROTO_HEADER_BYTES);
    assert_int_equal(AACMM_COMPUTE_REQ_BYTES(6u, 0x02u), 2 + 24 + 12);
    assert_int_equal(AACMM_COMPUTE_REQ_BYTES(6u, 0x01u), 2 + 24);
    assert_int_equal(AACMM_DIAG_BYTES(6u), 130);
    assert_int_equal(AACMM_DIAG_BYTES(4u), 108);
    assert_int_equal(AACMM_CONTENT_KNOWN, 0x03);

    /* the sample's layout: counts, then the temperatures, then the Jacobian */
    assert_true(vec_expected_msg("sample_evt_t", &m));
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_OK);
    assert_int_equal(n, 3 + 31 + 24 + 12);
    assert_int_equal(out[3 + 28], AACMM_CONTENT_TEMPERATURES);
    for (i = 0; i < 6; i++) {
        put_u32(want + 4 * i, m.u.sample.counts[i]);
        put_i16(want + 24 + 2 * i, m.u.sample.temp[i]);
    }
    assert_memory_equal(out + 3 + 31, want, 36);
    assert_int_equal(out[n - 4], 0x00); /* AACMM_TEMP_NONE: 0x8000 little-endian */
    assert_int_equal(out[n - 3], 0x80);
    /* any i16 reading passes both ways (the device sends what the sensor said) */
    m.u.sample.temp[0] = INT16_MIN;
    m.u.sample.temp[5] = INT16_MIN + 1;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_OK);
    assert_int_equal(aacmm_msg_decode(out, n, &got), AACMM_OK);
    assert_true(vec_msg_equal(&got, &m));
    /* without the bit: no temperature bytes, and the decoder's temp[] is 0 */
    m.u.sample.content = 0u;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_OK);
    assert_int_equal(n, 3 + 31 + 24);
    memset(&got, 0xA5, sizeof got);
    assert_int_equal(aacmm_msg_decode(out, n, &got), AACMM_OK);
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        assert_int_equal(got.u.sample.temp[i], 0);
    }
    m.u.sample.content = 0x04u;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);

    /* N 7, P 37 with both: more than a body; with the Jacobian alone it fits */
    assert_true(vec_expected_msg("measure_rsp7_tj", &m));
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_OK);
    assert_int_equal(n, 3 + 505);
    m.u.sample.params = 37u;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    assert_int_equal(n, 0);
    m.u.sample.content = AACMM_CONTENT_JACOBIAN;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_OK);
    assert_int_equal(n, 3 + 503);
    m.u.sample.content = AACMM_CONTENT_TEMPERATURES;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_OK);
    assert_int_equal(n, 3 + 31 + 28 + 14);
    assert_true(vec_expected_msg("trigger_evt7_tj", &m));
    m.u.trigger.sample.params = 37u;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);

    /* COMPUTE_REQ: every temperature -4000 .. 8500; none needed without the bit */
    assert_true(vec_expected_msg("compute_req_tj", &m));
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_OK);
    assert_int_equal(n, 3 + 2 + 24 + 12);
    for (i = 0; i < 6; i++) {
        put_i16(want + 2 * i, m.u.compute_req.temp[i]);
    }
    assert_memory_equal(out + 3 + 2 + 24, want, 12);
    m.u.compute_req.temp[2] = 8501;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    m.u.compute_req.temp[2] = -4001;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    m.u.compute_req.temp[2] = AACMM_TEMP_NONE;
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_ERR_RANGE);
    m.u.compute_req.content = AACMM_CONTENT_JACOBIAN; /* not sent: not checked */
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_OK);
    assert_int_equal(n, 3 + 2 + 24);
    memset(&got, 0xA5, sizeof got);
    assert_int_equal(aacmm_msg_decode(out, n, &got), AACMM_OK);
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        assert_int_equal(got.u.compute_req.temp[i], 0);
    }
    /* the decoder checks each of the N (the last one too) */
    assert_true(vec_expected_msg("compute_req_tj", &m));
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_OK);
    put_i16(out + n - 2, 8501);
    assert_int_equal(aacmm_msg_decode(out, n, &got), AACMM_ERR_RANGE);
    put_i16(out + n - 2, 8500);
    assert_int_equal(aacmm_msg_decode(out, n, &got), AACMM_OK);

    /* DIAG_RSP: u32 temp_faults after the N joint entries */
    assert_true(vec_expected_msg("diag_rsp_tf", &m));
    assert_int_equal(aacmm_msg_encode(&m, out, sizeof out, &n), AACMM_OK);
    assert_int_equal(n, 3 + 130);
    put_u32(want, 0x89ABCDEFu);
    assert_memory_equal(out + n - 4, want, 4);
    assert_int_equal(aacmm_msg_payload_len(AACMM_MSG_DIAG_RSP, out + 3, n - 3), 130);
}

static void test_param_set_crc(void **state)
{
    aacmm_param_set_t p, q;
    uint8_t buf[AACMM_PARAM_SET_PAPER_BYTES];
    uint32_t crc = 0;
    size_t i, len = 0;
    (void)state;
    vec_params(&p);
    assert_int_equal(aacmm_param_set_encode(&p, buf, sizeof buf, &len), AACMM_OK);
    assert_int_equal(aacmm_param_set_decode(buf, sizeof buf, &q), AACMM_OK);
    assert_int_equal(aacmm_param_set_crc32(&p, &crc), AACMM_OK);
    assert_int_equal(crc, aacmm_crc32(buf, sizeof buf));
    for (i = 0; i < g_nvec; i++) {
        if (strcmp(g_vec[i].kind, "crc") == 0 && strcmp(g_vec[i].name, "params") == 0) {
            uint32_t want = ((uint32_t)g_vec[i].b[0] << 24) | ((uint32_t)g_vec[i].b[1] << 16) |
                            ((uint32_t)g_vec[i].b[2] << 8) | g_vec[i].b[3];
            assert_int_equal(crc, want);
            assert_memory_equal(buf, g_vec[i].a, sizeof buf);
        }
    }
    assert_int_equal(aacmm_param_set_encode(&p, buf, sizeof buf - 1, &len), AACMM_ERR_BUFFER);
    assert_int_equal(aacmm_param_set_decode(buf, sizeof buf - 1, &q), AACMM_ERR_LENGTH);
}

static void test_point_to_wire(void **state)
{
    int clip = 9;
    const uint64_t nan_bits = 0x7FF8000000000000ull;
    double nan_value;
    (void)state;
    memcpy(&nan_value, &nan_bits, sizeof nan_value);
    assert_int_equal(aacmm_point_mm_to_wire(1234.56789, &clip), 12345679);
    assert_int_equal(clip, 0);
    assert_int_equal(aacmm_point_mm_to_wire(-0.00004, &clip), 0);
    assert_int_equal(aacmm_point_mm_to_wire(-0.00006, &clip), -1);
    assert_int_equal(aacmm_point_mm_to_wire(-2200.0, NULL), -22000000);
    assert_int_equal(aacmm_point_mm_to_wire(1e9, &clip), INT32_MAX);
    assert_int_equal(clip, 1);
    assert_int_equal(aacmm_point_mm_to_wire(-1e9, &clip), INT32_MIN);
    assert_int_equal(clip, 1);
    assert_int_equal(aacmm_point_mm_to_wire(nan_value, &clip), 0);
    assert_int_equal(clip, 1);
}

/* ---------------------------------------------------------------- framing */

static void test_frame_encode_limits(void **state)
{
    uint8_t body[AACMM_FRAME_MAX_BODY + 1], wire[AACMM_FRAME_MAX_WIRE + 8];
    size_t n = 0, cap, need = 0;
    (void)state;
    memset(body, 0x42, sizeof body);
    assert_int_equal(aacmm_frame_encode(body, AACMM_FRAME_MAX_BODY, wire, sizeof wire, &n), AACMM_OK);
    assert_true(n <= AACMM_FRAME_MAX_WIRE);
    assert_int_equal(wire[0], 0);
    assert_int_equal(wire[n - 1], 0);
    assert_null(memchr(wire + 1, 0, n - 2));
    assert_int_equal(aacmm_frame_encode(body, AACMM_FRAME_MAX_BODY + 1, wire, sizeof wire, &n),
                     AACMM_ERR_LENGTH);
    assert_int_equal(aacmm_frame_encode(body, 2, wire, sizeof wire, &n), AACMM_ERR_LENGTH);
    assert_int_equal(aacmm_frame_encode(body, 10, wire, sizeof wire, &need), AACMM_OK);
    assert_int_equal(need, 17); /* 0x00, code, 10 + 4 bytes, 0x00 */
    for (cap = 0; cap < need; cap++) {
        assert_int_equal(aacmm_frame_encode(body, 10, wire + sizeof wire - cap, cap, &n),
                         AACMM_ERR_BUFFER);
        assert_int_equal(n, 0);
    }
}

static size_t feed_all(aacmm_deframer_t *d, const uint8_t *data, size_t len, size_t chunk,
                       uint8_t bodies[][AACMM_FRAME_MAX_BODY], size_t *lens, size_t max)
{
    size_t got = 0, off = 0;
    while (off < len) {
        size_t take = len - off < chunk ? len - off : chunk;
        size_t used = 0;
        while (used < take) {
            const uint8_t *b = NULL;
            size_t bl = 0;
            size_t c = aacmm_deframer_feed(d, data + off + used, take - used, &b, &bl);
            assert_true(c >= 1 && c <= take - used);
            used += c;
            if (b != NULL) {
                assert_true(bl >= AACMM_FRAME_MIN_BODY && bl <= AACMM_FRAME_MAX_BODY);
                if (got < max) {
                    memcpy(bodies[got], b, bl);
                    lens[got] = bl;
                }
                got++;
            }
        }
        off += take;
    }
    return got;
}

static uint8_t g_stream[40000];
static uint8_t g_bodies[64][AACMM_FRAME_MAX_BODY];
static size_t g_lens[64];

static void test_deframer_vectors_any_chunking(void **state)
{
    static const size_t chunks[] = {1, 2, 3, 7, 64, 40000};
    size_t i, k, len = 0, nmsg = 0;
    const uint8_t garbage[] = {0x13, 0x37, 0x00, 0xFF, 0xFE, 0x01, 0x02};
    (void)state;
    /* all valid frames, separated by garbage and by the bad-frame vectors */
    for (i = 0; i < g_nvec; i++) {
        const vec_record_t *r = &g_vec[i];
        if (strcmp(r->kind, "msg") == 0) {
            memcpy(g_stream + len, r->b, r->b_len);
            len += r->b_len;
            memcpy(g_stream + len, garbage, sizeof garbage);
            len += sizeof garbage;
            nmsg++;
        } else if (strcmp(r->kind, "badframe") == 0) {
            memcpy(g_stream + len, r->a, r->a_len);
            len += r->a_len;
        }
    }
    for (k = 0; k < sizeof chunks / sizeof chunks[0]; k++) {
        aacmm_deframer_t d;
        size_t got, m = 0;
        aacmm_deframer_init(&d);
        got = feed_all(&d, g_stream, len, chunks[k], g_bodies, g_lens, 64);
        assert_int_equal(got, nmsg);
        assert_int_equal(d.stats.frames_ok, nmsg);
        for (i = 0; i < g_nvec; i++) {
            if (strcmp(g_vec[i].kind, "msg") == 0) {
                assert_int_equal(g_lens[m], g_vec[i].a_len);
                assert_memory_equal(g_bodies[m], g_vec[i].a, g_vec[i].a_len);
                m++;
            }
        }
        assert_true(d.stats.crc_errors >= 2);
        assert_true(d.stats.cobs_errors >= 2);
        assert_true(d.stats.oversize >= 1);
        assert_true(d.stats.runts >= 1);
    }
}

static void test_deframer_bad_frame_vectors(void **state)
{
    size_t i, checked = 0;
    const vec_record_t *good = NULL;
    (void)state;
    for (i = 0; i < g_nvec; i++) {
        if (strcmp(g_vec[i].kind, "msg") == 0 && good == NULL) {
            good = &g_vec[i];
        }
    }
    assert_non_null(good);
    for (i = 0; i < g_nvec; i++) {
        const vec_record_t *r = &g_vec[i];
        aacmm_deframer_t d;
        aacmm_deframer_stats_t before;
        const uint32_t *counter;
        size_t got;
        if (strcmp(r->kind, "badframe") != 0) {
            continue;
        }
        aacmm_deframer_init(&d);
        before = d.stats;
        if (strcmp(r->word, "crc_errors") == 0) {
            counter = &d.stats.crc_errors;
        } else if (strcmp(r->word, "cobs_errors") == 0) {
            counter = &d.stats.cobs_errors;
        } else if (strcmp(r->word, "runts") == 0) {
            counter = &d.stats.runts;
        } else if (strcmp(r->word, "oversize") == 0) {
            counter = &d.stats.oversize;
        } else {
            fail_msg("unknown counter %s", r->word);
            return;
        }
        got = feed_all(&d, r->a, r->a_len, 5, g_bodies, g_lens, 64);
        assert_int_equal(got, 0);
        assert_int_equal(*counter, 1);
        assert_int_equal(d.stats.frames_ok, before.frames_ok);
        assert_true(d.stats.bytes_dropped > 0);
        assert_int_not_equal(d.last_error, AACMM_OK);
        /* resynchronised: the next good frame gets through */
        got = feed_all(&d, good->b, good->b_len, 3, g_bodies, g_lens, 64);
        assert_int_equal(got, 1);
        assert_memory_equal(g_bodies[0], good->a, good->a_len);
        checked++;
    }
    assert_int_equal(checked, count_kind("badframe"));
    assert_true(checked >= 6);
}

static void test_deframer_torn_without_leading_delimiter(void **state)
{
    /* A frame cut short, followed by frames that carry only the trailing
     * delimiter: the torn bytes poison one frame at most. */
    uint8_t wire[3][AACMM_FRAME_MAX_WIRE];
    size_t wl[3];
    uint8_t body[3][40];
    size_t i, len = 0, got;
    aacmm_deframer_t d;
    (void)state;
    for (i = 0; i < 3; i++) {
        size_t k;
        body[i][0] = 1;
        body[i][1] = AACMM_MSG_PING_REQ;
        body[i][2] = (uint8_t)i;
        for (k = 3; k < 7; k++) {
            body[i][k] = (uint8_t)(k * 11u + i);
        }
        assert_int_equal(aacmm_frame_encode(body[i], 7, wire[i], sizeof wire[i], &wl[i]), AACMM_OK);
    }
    memcpy(g_stream, wire[0], wl[0] - 4); /* torn: no end */
    len = wl[0] - 4;
    memcpy(g_stream + len, wire[1] + 1, wl[1] - 1); /* no leading 0x00 */
    len += wl[1] - 1;
    memcpy(g_stream + len, wire[2] + 1, wl[2] - 1);
    len += wl[2] - 1;
    aacmm_deframer_init(&d);
    got = feed_all(&d, g_stream, len, 1, g_bodies, g_lens, 64);
    assert_int_equal(got, 1);
    assert_memory_equal(g_bodies[0], body[2], 7);
    assert_int_equal(d.stats.crc_errors + d.stats.cobs_errors, 1);
}

static void test_deframer_long_garbage_and_null(void **state)
{
    aacmm_deframer_t d;
    size_t i, got;
    const uint8_t *b = (const uint8_t *)1;
    size_t bl = 9;
    (void)state;
    for (i = 0; i < 5000; i++) {
        g_stream[i] = (uint8_t)(1u + (i * 7u) % 255u);
    }
    aacmm_deframer_init(&d);
    got = feed_all(&d, g_stream, 5000, 100, g_bodies, g_lens, 64);
    assert_int_equal(got, 0);
    assert_int_equal(d.stats.oversize, 1); /* counted once, not once per byte */
    assert_int_equal(aacmm_deframer_feed(NULL, g_stream, 5, &b, &bl), 0);
    assert_null(b);
    assert_int_equal(bl, 0);
    assert_int_equal(aacmm_deframer_feed(&d, g_stream, 5, NULL, &bl), 0);
}

/* ---------------------------------------------------------------- CAN frames */

static void test_can_sample_frames(void **state)
{
    aacmm_sample_t s;
    aacmm_msg_t m7;
    aacmm_can_frame_t f[AACMM_CAN_SAMPLE_FRAMES_MAX], t;
    size_t i, k = 0, nf = 0;
    (void)state;
    /* the 7-joint sample: seven frames, as the vectors (and the DBC) say */
    assert_true(vec_expected_msg("sample_evt7", &m7));
    assert_int_equal(aacmm_can_sample_encode(&m7.u.sample, 2, f, &nf), AACMM_OK);
    assert_int_equal(nf, AACMM_CAN_SAMPLE_FRAMES(7u));
    for (i = 0; i < g_nvec; i++) {
        const vec_record_t *r = &g_vec[i];
        if (strcmp(r->kind, "can") != 0 || strncmp(r->name, "sample_7_n2_", 12) != 0) {
            continue;
        }
        assert_true(k < nf);
        assert_int_equal(f[k].id, r->id);
        assert_memory_equal(f[k].data, r->b, 8);
        k++;
    }
    assert_int_equal(k, 7);
    /* a sample with temperatures: the frames carry its TEMP_FAULT status bit
     * (in PointZ's low 16 status bits), not the temperatures */
    assert_true(vec_expected_msg("sample_evt_t", &m7));
    assert_int_equal(aacmm_can_sample_encode(&m7.u.sample, 1, f, &nf), AACMM_OK);
    assert_int_equal(nf, AACMM_CAN_SAMPLE_FRAMES(6u));
    k = 0;
    for (i = 0; i < g_nvec; i++) {
        const vec_record_t *r = &g_vec[i];
        if (strcmp(r->kind, "can") != 0 || strncmp(r->name, "sample_t_n1_", 12) != 0) {
            continue;
        }
        assert_true(k < nf);
        assert_int_equal(f[k].id, r->id);
        assert_memory_equal(f[k].data, r->b, 8);
        k++;
    }
    assert_int_equal(k, 6);
    assert_int_equal(f[nf - 1].data[4] | (f[nf - 1].data[5] << 8),
                     AACMM_SAMPLE_POINT_VALID | AACMM_SAMPLE_TEMP_FAULT);
    k = 0;
    vec_sample_a(&s);
    assert_int_equal(aacmm_can_sample_encode(&s, 5, f, &nf), AACMM_OK);
    assert_int_equal(nf, 6);
    for (i = 0; i < g_nvec; i++) {
        const vec_record_t *r = &g_vec[i];
        if (strcmp(r->kind, "can") != 0 || strncmp(r->name, "sample_a_n5_", 12) != 0) {
            continue;
        }
        assert_true(k < nf);
        assert_int_equal(f[k].id, r->id);
        assert_int_equal(f[k].dlc, r->b_len);
        assert_memory_equal(f[k].data, r->b, 8);
        k++;
    }
    assert_int_equal(k, AACMM_CAN_SAMPLE_FRAMES(6u));
    assert_int_equal(aacmm_can_trigger_encode(s.seq, 0, 1, 5, &t), AACMM_OK);
    for (i = 0; i < g_nvec; i++) {
        if (strcmp(g_vec[i].kind, "can") == 0 && strcmp(g_vec[i].name, "trigger_n5") == 0) {
            assert_int_equal(t.id, g_vec[i].id);
            assert_memory_equal(t.data, g_vec[i].b, 8);
            k++;
        }
    }
    assert_int_equal(k, AACMM_CAN_SAMPLE_FRAMES(6u) + 1);
    assert_int_equal(aacmm_can_sample_encode(&s, 16, f, &nf), AACMM_ERR_RANGE);
    s.joints = 3u;
    assert_int_equal(aacmm_can_sample_encode(&s, 0, f, &nf), AACMM_ERR_RANGE);
    s.joints = 4u;
    assert_int_equal(aacmm_can_sample_encode(&s, 0, f, &nf), AACMM_OK);
    assert_int_equal(nf, 5);
    assert_int_equal(aacmm_can_trigger_encode(1, 0, 2, 0, &t), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_can_sample_encode(NULL, 0, f, &nf), AACMM_ERR_NULL);
}

/* ---------------------------------------------------------------- ISO-TP */

typedef struct {
    aacmm_isotp_t tp;
    uint8_t rx[AACMM_PROTO_MAX_BODY];
    uint8_t tx[AACMM_PROTO_MAX_BODY];
} endpoint_t;

static void endpoint_init(endpoint_t *e, uint32_t tx_id, uint32_t rx_id, uint8_t bs, uint8_t stmin,
                          size_t rx_cap)
{
    aacmm_isotp_config_t cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.tx_id = tx_id;
    cfg.rx_id = rx_id;
    cfg.rx_buf = e->rx;
    cfg.rx_cap = rx_cap;
    cfg.tx_buf = e->tx;
    cfg.tx_cap = sizeof e->tx;
    cfg.block_size = bs;
    cfg.st_min = stmin;
    cfg.padding = 0xCC;
    cfg.max_wait = 2;
    cfg.timeout_ms = 100;
    assert_int_equal(aacmm_isotp_init(&e->tp, &cfg), AACMM_OK);
}

static aacmm_can_frame_t mkframe(uint32_t id, const uint8_t *data, uint8_t dlc)
{
    aacmm_can_frame_t f;
    memset(&f, 0, sizeof f);
    f.id = id;
    f.dlc = dlc;
    memcpy(f.data, data, dlc);
    return f;
}

static void test_isotp_matches_can_isotp_vectors(void **state)
{
    size_t i, checked = 0;
    (void)state;
    for (i = 0; i < g_nvec; i++) {
        const vec_record_t *r = &g_vec[i];
        endpoint_t tx, rx;
        aacmm_can_frame_t f;
        const uint8_t *msg = NULL;
        size_t k, n = 0;
        uint32_t peer;
        if (strcmp(r->kind, "isotp") != 0) {
            continue;
        }
        peer = (r->id >= AACMM_CAN_ID_ISOTP_RESPONSE) ? r->id - 0x80u : r->id + 0x80u;
        /* C sender produces the frames can-isotp produced */
        endpoint_init(&tx, r->id, peer, 0, 0, sizeof tx.rx);
        assert_int_equal(aacmm_isotp_send(&tx.tp, r->a, r->a_len, 0), AACMM_OK);
        for (k = 0; k < r->n_frames; k++) {
            assert_int_equal(aacmm_isotp_poll(&tx.tp, 1, &f), 1);
            assert_int_equal(f.id, r->id);
            assert_int_equal(f.dlc, 8);
            assert_memory_equal(f.data, r->frames[k], r->frame_len[k]);
            if (k == 0 && r->n_frames > 1) {
                const uint8_t cts[3] = {0x30, 0, 0};
                assert_int_equal(aacmm_isotp_poll(&tx.tp, 1, &f), 0); /* waits for FC */
                f = mkframe(peer, cts, 3);
                aacmm_isotp_on_frame(&tx.tp, &f, 1);
            }
        }
        assert_int_equal(aacmm_isotp_poll(&tx.tp, 5, &f), 0);
        assert_int_equal(aacmm_isotp_tx_result(&tx.tp), AACMM_OK);
        assert_int_equal(tx.tp.stats.tx_messages, 1);
        /* C receiver reassembles can-isotp's frames */
        endpoint_init(&rx, peer, r->id, 0, 0, sizeof rx.rx);
        for (k = 0; k < r->n_frames; k++) {
            f = mkframe(r->id, r->frames[k], (uint8_t)r->frame_len[k]);
            aacmm_isotp_on_frame(&rx.tp, &f, (uint32_t)k);
            if (k == 0 && r->n_frames > 1) {
                assert_int_equal(aacmm_isotp_poll(&rx.tp, 0, &f), 1);
                assert_int_equal(f.id, peer);
                assert_int_equal(f.data[0], 0x30);
            }
        }
        assert_int_equal(aacmm_isotp_receive(&rx.tp, &msg, &n), 1);
        assert_int_equal(n, r->a_len);
        assert_memory_equal(msg, r->a, n);
        assert_int_equal(aacmm_isotp_receive(&rx.tp, &msg, &n), 0);
        checked++;
    }
    assert_int_equal(checked, 5);
}

/* Run two endpoints against each other on a simulated bus. */
static int run_link(endpoint_t *a, endpoint_t *b, uint32_t *now, uint32_t max_ms, size_t *frames)
{
    aacmm_can_frame_t f;
    uint32_t end = *now + max_ms;
    while (*now != end) {
        int moved = 1;
        while (moved) {
            moved = 0;
            while (aacmm_isotp_poll(&a->tp, *now, &f)) {
                aacmm_isotp_on_frame(&b->tp, &f, *now);
                (*frames)++;
                moved = 1;
            }
            while (aacmm_isotp_poll(&b->tp, *now, &f)) {
                aacmm_isotp_on_frame(&a->tp, &f, *now);
                (*frames)++;
                moved = 1;
            }
        }
        if (b->tp.rx_state == 2 && aacmm_isotp_tx_result(&a->tp) != AACMM_ERR_BUSY) {
            return 1;
        }
        if (aacmm_isotp_tx_result(&a->tp) != AACMM_ERR_BUSY && aacmm_isotp_tx_result(&a->tp) != AACMM_OK) {
            return 0;
        }
        (*now)++;
    }
    return 0;
}

static void test_isotp_loopback_block_size_stmin(void **state)
{
    static const uint8_t bss[] = {0, 1, 3, 8};
    static const uint8_t stmins[] = {0, 2, 0xF3};
    size_t bi, si, len;
    (void)state;
    for (bi = 0; bi < sizeof bss; bi++) {
        for (si = 0; si < sizeof stmins; si++) {
            for (len = 1; len <= AACMM_PROTO_MAX_BODY; len += (len < 20 ? 1 : 97)) {
                endpoint_t host, dev;
                uint8_t msg[AACMM_PROTO_MAX_BODY];
                const uint8_t *got = NULL;
                size_t n = 0, i, frames = 0;
                uint32_t now = 0xFFFFFFF0u; /* cross the clock wrap */
                for (i = 0; i < len; i++) {
                    msg[i] = (uint8_t)(i * 7u + len);
                }
                endpoint_init(&host, 0x605, 0x685, 0, 0, sizeof host.rx);
                endpoint_init(&dev, 0x685, 0x605, bss[bi], stmins[si], sizeof dev.rx);
                assert_int_equal(aacmm_isotp_send(&host.tp, msg, len, now), AACMM_OK);
                assert_int_equal(aacmm_isotp_send(&host.tp, msg, len, now), AACMM_ERR_BUSY);
                assert_true(run_link(&host, &dev, &now, 5000, &frames));
                assert_int_equal(aacmm_isotp_receive(&dev.tp, &got, &n), 1);
                assert_int_equal(n, len);
                assert_memory_equal(got, msg, len);
                assert_int_equal(aacmm_isotp_tx_result(&host.tp), AACMM_OK);
                assert_int_equal(dev.tp.stats.rx_messages, 1);
                assert_int_equal(dev.tp.stats.rx_sequence_errors + dev.tp.stats.rx_timeouts, 0);
            }
        }
    }
}

static void test_isotp_receiver_errors(void **state)
{
    endpoint_t e;
    aacmm_can_frame_t f, out;
    const uint8_t *m = NULL;
    size_t n = 0;
    const uint8_t ff20[8] = {0x10, 20, 1, 2, 3, 4, 5, 6};
    const uint8_t cf1[8] = {0x21, 7, 8, 9, 10, 11, 12, 13};
    const uint8_t cf3[8] = {0x23, 7, 8, 9, 10, 11, 12, 13};
    const uint8_t sf0[8] = {0x00, 1, 2, 3, 4, 5, 6, 7};
    const uint8_t sf8[8] = {0x08, 1, 2, 3, 4, 5, 6, 7};
    const uint8_t sf3[8] = {0x03, 1, 2, 3, 0xCC, 0xCC, 0xCC, 0xCC};
    const uint8_t ff7[8] = {0x10, 7, 1, 2, 3, 4, 5, 6};
    const uint8_t ffbig[8] = {0x1F, 0xFF, 1, 2, 3, 4, 5, 6};
    const uint8_t pci4[8] = {0x40, 0, 0, 0, 0, 0, 0, 0};
    const uint8_t fc[3] = {0x30, 0, 0};
    (void)state;
    endpoint_init(&e, 0x685, 0x605, 0, 0, 64);

    /* frames for other ids are ignored entirely */
    f = mkframe(0x606, sf3, 8);
    aacmm_isotp_on_frame(&e.tp, &f, 0);
    assert_int_equal(aacmm_isotp_receive(&e.tp, &m, &n), 0);

    /* malformed single frames */
    f = mkframe(0x605, sf0, 8);
    aacmm_isotp_on_frame(&e.tp, &f, 0);
    f = mkframe(0x605, sf8, 8);
    aacmm_isotp_on_frame(&e.tp, &f, 0);
    f = mkframe(0x605, sf3, 3); /* DLC shorter than SF_DL + 1 */
    aacmm_isotp_on_frame(&e.tp, &f, 0);
    f = mkframe(0x605, sf3, 0);
    aacmm_isotp_on_frame(&e.tp, &f, 0);
    f = mkframe(0x605, sf3, 8);
    f.dlc = 9;
    aacmm_isotp_on_frame(&e.tp, &f, 0);
    f = mkframe(0x605, ff7, 8); /* FF with a length a SF could carry */
    aacmm_isotp_on_frame(&e.tp, &f, 0);
    f = mkframe(0x605, ff20, 7); /* FF must have DLC 8 */
    aacmm_isotp_on_frame(&e.tp, &f, 0);
    f = mkframe(0x605, pci4, 8);
    aacmm_isotp_on_frame(&e.tp, &f, 0);
    assert_int_equal(e.tp.stats.rx_bad_frames, 8);
    assert_int_equal(aacmm_isotp_receive(&e.tp, &m, &n), 0);

    /* CF while idle, FC while not sending */
    f = mkframe(0x605, cf1, 8);
    aacmm_isotp_on_frame(&e.tp, &f, 0);
    f = mkframe(0x605, fc, 3);
    aacmm_isotp_on_frame(&e.tp, &f, 0);
    assert_int_equal(e.tp.stats.rx_unexpected, 2);

    /* wrong sequence number aborts */
    f = mkframe(0x605, ff20, 8);
    aacmm_isotp_on_frame(&e.tp, &f, 10);
    assert_int_equal(aacmm_isotp_poll(&e.tp, 10, &out), 1); /* FC CTS */
    assert_int_equal(out.data[0], 0x30);
    f = mkframe(0x605, cf3, 8);
    aacmm_isotp_on_frame(&e.tp, &f, 11);
    assert_int_equal(e.tp.stats.rx_sequence_errors, 1);
    f = mkframe(0x605, cf1, 8);
    aacmm_isotp_on_frame(&e.tp, &f, 11); /* now unexpected */
    assert_int_equal(e.tp.stats.rx_unexpected, 3);

    /* N_Cr timeout aborts */
    f = mkframe(0x605, ff20, 8);
    aacmm_isotp_on_frame(&e.tp, &f, 20);
    assert_int_equal(aacmm_isotp_poll(&e.tp, 20, &out), 1);
    assert_int_equal(aacmm_isotp_poll(&e.tp, 119, &out), 0);
    assert_int_equal(e.tp.stats.rx_timeouts, 0);
    assert_int_equal(aacmm_isotp_poll(&e.tp, 120, &out), 0);
    assert_int_equal(e.tp.stats.rx_timeouts, 1);

    /* too long for the buffer: FC overflow, nothing stored */
    f = mkframe(0x605, ffbig, 8);
    aacmm_isotp_on_frame(&e.tp, &f, 200);
    assert_int_equal(e.tp.stats.rx_overflows, 1);
    assert_int_equal(aacmm_isotp_poll(&e.tp, 200, &out), 1);
    assert_int_equal(out.data[0], 0x32);

    /* a SF interrupting a reception replaces it */
    f = mkframe(0x605, ff20, 8);
    aacmm_isotp_on_frame(&e.tp, &f, 300);
    (void)aacmm_isotp_poll(&e.tp, 300, &out);
    f = mkframe(0x605, sf3, 8);
    aacmm_isotp_on_frame(&e.tp, &f, 301);
    assert_int_equal(e.tp.stats.rx_interrupted, 1);
    assert_int_equal(aacmm_isotp_receive(&e.tp, &m, &n), 1);
    assert_int_equal(n, 3);
    assert_int_equal(m[2], 3);

    /* a final CF with a DLC too short for the remaining bytes aborts */
    f = mkframe(0x605, ff20, 8);
    aacmm_isotp_on_frame(&e.tp, &f, 400);
    (void)aacmm_isotp_poll(&e.tp, 400, &out);
    f = mkframe(0x605, cf1, 8);
    aacmm_isotp_on_frame(&e.tp, &f, 401);
    {
        const uint8_t cf2[8] = {0x22, 14, 15, 16, 17, 18, 19, 20};
        f = mkframe(0x605, cf2, 4); /* 7 bytes remain, DLC covers 3 */
        aacmm_isotp_on_frame(&e.tp, &f, 402);
    }
    assert_int_equal(aacmm_isotp_receive(&e.tp, &m, &n), 0);
    assert_int_equal(e.tp.stats.rx_bad_frames, 9);
    assert_int_equal(e.tp.stats.rx_messages, 1);
}

static void test_isotp_sender_errors(void **state)
{
    endpoint_t e;
    aacmm_can_frame_t f, out;
    uint8_t msg[100];
    const uint8_t wait[3] = {0x31, 0, 0};
    const uint8_t ovfl[3] = {0x32, 0, 0};
    const uint8_t bad_fs[3] = {0x35, 0, 0};
    aacmm_isotp_config_t cfg;
    (void)state;
    memset(msg, 0x77, sizeof msg);
    endpoint_init(&e, 0x685, 0x605, 0, 0, 64);
    assert_int_equal(aacmm_isotp_send(&e.tp, msg, 0, 0), AACMM_ERR_LENGTH);
    assert_int_equal(aacmm_isotp_send(&e.tp, msg, sizeof e.tx + 1, 0), AACMM_ERR_LENGTH);
    assert_int_equal(aacmm_isotp_send(NULL, msg, 1, 0), AACMM_ERR_NULL);

    /* N_Bs: no flow control after the FF */
    assert_int_equal(aacmm_isotp_send(&e.tp, msg, sizeof msg, 0), AACMM_OK);
    assert_int_equal(aacmm_isotp_poll(&e.tp, 0, &out), 1);
    assert_int_equal(out.data[0], 0x10);
    assert_int_equal(aacmm_isotp_poll(&e.tp, 99, &out), 0);
    assert_int_equal(aacmm_isotp_tx_result(&e.tp), AACMM_ERR_BUSY);
    assert_int_equal(aacmm_isotp_poll(&e.tp, 100, &out), 0);
    assert_int_equal(aacmm_isotp_tx_result(&e.tp), AACMM_ERR_TIMEOUT);
    assert_int_equal(e.tp.stats.tx_timeouts, 1);

    /* receiver refuses the length */
    assert_int_equal(aacmm_isotp_send(&e.tp, msg, sizeof msg, 200), AACMM_OK);
    assert_int_equal(aacmm_isotp_poll(&e.tp, 200, &out), 1);
    f = mkframe(0x605, ovfl, 3);
    aacmm_isotp_on_frame(&e.tp, &f, 201);
    assert_int_equal(aacmm_isotp_tx_result(&e.tp), AACMM_ERR_OVERFLOW);
    assert_int_equal(e.tp.stats.tx_refused, 1);

    /* too many WAIT frames (max_wait = 2), and WAIT restarts the timer */
    assert_int_equal(aacmm_isotp_send(&e.tp, msg, sizeof msg, 300), AACMM_OK);
    assert_int_equal(aacmm_isotp_poll(&e.tp, 300, &out), 1);
    f = mkframe(0x605, wait, 3);
    aacmm_isotp_on_frame(&e.tp, &f, 390);
    assert_int_equal(aacmm_isotp_poll(&e.tp, 450, &out), 0);
    assert_int_equal(aacmm_isotp_tx_result(&e.tp), AACMM_ERR_BUSY);
    aacmm_isotp_on_frame(&e.tp, &f, 460);
    aacmm_isotp_on_frame(&e.tp, &f, 470);
    assert_int_equal(aacmm_isotp_tx_result(&e.tp), AACMM_ERR_FRAME);
    assert_int_equal(e.tp.stats.tx_aborted, 1);

    /* invalid flow status, and a flow control frame with a short DLC */
    assert_int_equal(aacmm_isotp_send(&e.tp, msg, sizeof msg, 500), AACMM_OK);
    assert_int_equal(aacmm_isotp_poll(&e.tp, 500, &out), 1);
    f = mkframe(0x605, bad_fs, 2);
    aacmm_isotp_on_frame(&e.tp, &f, 501);
    assert_int_equal(e.tp.stats.rx_bad_frames, 1);
    f = mkframe(0x605, bad_fs, 3);
    aacmm_isotp_on_frame(&e.tp, &f, 501);
    assert_int_equal(aacmm_isotp_tx_result(&e.tp), AACMM_ERR_FRAME);
    assert_int_equal(e.tp.stats.tx_aborted, 2);

    /* configuration checks */
    cfg = e.tp.cfg;
    cfg.rx_id = cfg.tx_id;
    assert_int_equal(aacmm_isotp_init(&e.tp, &cfg), AACMM_ERR_RANGE);
    cfg = e.tp.cfg;
    cfg.tx_id = 0x800;
    assert_int_equal(aacmm_isotp_init(&e.tp, &cfg), AACMM_ERR_RANGE);
    cfg = e.tp.cfg;
    cfg.timeout_ms = 0;
    assert_int_equal(aacmm_isotp_init(&e.tp, &cfg), AACMM_ERR_RANGE);
    cfg = e.tp.cfg;
    cfg.rx_buf = NULL;
    assert_int_equal(aacmm_isotp_init(&e.tp, &cfg), AACMM_ERR_NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_crc32_check_value),
        cmocka_unit_test(test_cobs_known_encodings),
        cmocka_unit_test(test_cobs_rejects),
        cmocka_unit_test(test_vectors_encode_decode),
        cmocka_unit_test(test_vectors_bad_bodies),
        cmocka_unit_test(test_truncated_and_extended),
        cmocka_unit_test(test_unknown_types_and_version),
        cmocka_unit_test(test_encode_rejects),
        cmocka_unit_test(test_temperatures),
        cmocka_unit_test(test_param_set_encoder_rule),
        cmocka_unit_test(test_param_set_shape_rules),
        cmocka_unit_test(test_helpers_counted_decode_error_reply),
        cmocka_unit_test(test_param_set_crc),
        cmocka_unit_test(test_point_to_wire),
        cmocka_unit_test(test_frame_encode_limits),
        cmocka_unit_test(test_deframer_vectors_any_chunking),
        cmocka_unit_test(test_deframer_bad_frame_vectors),
        cmocka_unit_test(test_deframer_torn_without_leading_delimiter),
        cmocka_unit_test(test_deframer_long_garbage_and_null),
        cmocka_unit_test(test_can_sample_frames),
        cmocka_unit_test(test_isotp_matches_can_isotp_vectors),
        cmocka_unit_test(test_isotp_loopback_block_size_stmin),
        cmocka_unit_test(test_isotp_receiver_errors),
        cmocka_unit_test(test_isotp_sender_errors),
    };
    g_nvec = vec_load(VECTORS_PATH, g_vec, VEC_MAX_RECORDS);
    if (g_nvec < 50) {
        fprintf(stderr, "too few vectors (%zu) in %s\n", g_nvec, VECTORS_PATH);
        return 1;
    }
    return cmocka_run_group_tests_name("protocol", tests, NULL, NULL);
}
