/*
 * libFuzzer harness over every decoder that sees untrusted bytes:
 *
 *   byte 0 % 5 == 0  serial deframer fed in chunks, then the message decoder
 *                    on every delivered body
 *                 1  message decoder on the raw input as a body
 *                 2  ISO-TP endpoint fed a sequence of CAN frames (receiver
 *                    and the sender's flow-control handling), then the
 *                    message decoder on every reassembled message
 *                 3  COBS decoder into an exact-size buffer
 *                 4  absolute-encoder frame decoder (aacmm/encoder_frame.h):
 *                    [interface][bits][n_bits][up to 12 line bytes]
 *
 * Beyond "no crash, no sanitizer report" it checks properties: a decoded
 * message re-encodes to exactly the same bytes (the codec is canonical), a
 * delivered frame body has a legal length, counters only grow; an accepted
 * encoder frame gives a position below 2^bits, and every single flipped
 * sample inside an accepted BiSS-C frame's CRC-covered bits or CRC is caught.
 *
 * Build: clang -fsanitize=fuzzer,address,undefined (see mk/protocol.mk).
 */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "aacmm/cobs.h"
#include "aacmm/encoder_frame.h"
#include "aacmm/frame.h"
#include "aacmm/isotp.h"
#include "aacmm/proto.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define CHECK(c)                                                                                   \
    do {                                                                                           \
        if (!(c)) {                                                                                \
            abort();                                                                               \
        }                                                                                          \
    } while (0)

static void check_body(const uint8_t *body, size_t len)
{
    aacmm_msg_t msg;
    uint8_t again[AACMM_PROTO_MAX_BODY];
    size_t n = 0;
    if (aacmm_msg_decode(body, len, &msg) == AACMM_OK) {
        CHECK(aacmm_msg_encode(&msg, again, sizeof again, &n) == AACMM_OK);
        CHECK(n == len);
        CHECK(memcmp(again, body, len) == 0);
    }
}

static void fuzz_deframer(const uint8_t *data, size_t size)
{
    static aacmm_deframer_t d;
    size_t chunk, off = 0;
    uint32_t last_ok = 0;
    if (size == 0) {
        return;
    }
    chunk = (size_t)data[0] % 17u + 1u;
    data++;
    size--;
    aacmm_deframer_init(&d);
    while (off < size) {
        size_t take = size - off < chunk ? size - off : chunk;
        size_t used = 0;
        while (used < take) {
            const uint8_t *body = NULL;
            size_t blen = 0;
            size_t c = aacmm_deframer_feed(&d, data + off + used, take - used, &body, &blen);
            CHECK(c >= 1 && c <= take - used);
            used += c;
            if (body != NULL) {
                CHECK(blen >= AACMM_FRAME_MIN_BODY && blen <= AACMM_FRAME_MAX_BODY);
                CHECK(d.stats.frames_ok == last_ok + 1u);
                last_ok = d.stats.frames_ok;
                check_body(body, blen);
            }
        }
        off += take;
    }
}

static void fuzz_body(const uint8_t *data, size_t size)
{
    uint8_t wire[AACMM_FRAME_MAX_WIRE];
    size_t n = 0;
    check_body(data, size);
    if (size >= AACMM_FRAME_MIN_BODY && size <= AACMM_FRAME_MAX_BODY) {
        static aacmm_deframer_t d;
        const uint8_t *body = NULL;
        size_t blen = 0, used;
        CHECK(aacmm_frame_encode(data, size, wire, sizeof wire, &n) == AACMM_OK);
        aacmm_deframer_init(&d);
        used = aacmm_deframer_feed(&d, wire, n, &body, &blen);
        CHECK(used == n && body != NULL && blen == size && memcmp(body, data, size) == 0);
    }
}

static void fuzz_isotp(const uint8_t *data, size_t size)
{
    static aacmm_isotp_t tp;
    static uint8_t rx[AACMM_PROTO_MAX_BODY], tx[AACMM_PROTO_MAX_BODY];
    aacmm_isotp_config_t cfg;
    uint32_t now = 0;
    size_t off = 1;
    if (size < 1) {
        return;
    }
    memset(&cfg, 0, sizeof cfg);
    cfg.tx_id = 0x685;
    cfg.rx_id = 0x605;
    cfg.rx_buf = rx;
    cfg.rx_cap = (size_t)(data[0] & 0x0Fu) * 32u + 1u; /* 1 .. 481 */
    cfg.tx_buf = tx;
    cfg.tx_cap = sizeof tx;
    cfg.block_size = (uint8_t)(data[0] >> 4);
    cfg.st_min = 0;
    cfg.padding = 0xCC;
    cfg.max_wait = 3;
    cfg.timeout_ms = 50;
    CHECK(aacmm_isotp_init(&tp, &cfg) == AACMM_OK);
    /* a transmission in progress, so flow-control frames are exercised */
    memset(tx, 0, sizeof tx);
    CHECK(aacmm_isotp_send(&tp, data, size < 300 ? (size > 0 ? size : 1) : 300, now) == AACMM_OK);
    /* records: [dt][dlc|flags][8 data bytes] */
    while (off + 10u <= size) {
        aacmm_can_frame_t f, out;
        const uint8_t *msg = NULL;
        size_t len = 0;
        int guard = 0;
        now += data[off];
        f.id = (data[off + 1] & 0x80u) ? 0x606u : 0x605u;
        f.dlc = (uint8_t)(data[off + 1] & 0x0Fu); /* 0..15: invalid DLCs included */
        memcpy(f.data, &data[off + 2], 8);
        aacmm_isotp_on_frame(&tp, &f, now);
        while (aacmm_isotp_poll(&tp, now, &out)) {
            CHECK(out.dlc == 8u && out.id == 0x685u);
            CHECK(++guard < 10000);
        }
        if (aacmm_isotp_receive(&tp, &msg, &len)) {
            CHECK(len >= 1u && len <= cfg.rx_cap);
            check_body(msg, len);
        }
        if (aacmm_isotp_tx_result(&tp) != AACMM_ERR_BUSY && (data[off + 1] & 0x40u)) {
            size_t want = 10u + (size_t)data[off + 2];
            (void)aacmm_isotp_send(&tp, &data[off], want < size - off ? want : size - off, now);
        }
        off += 10u;
    }
}

static void fuzz_cobs(const uint8_t *data, size_t size)
{
    uint8_t *out;
    size_t cap = size, n = 0;
    /* exact-size heap buffer so ASan catches any overrun (test code only) */
    out = (uint8_t *)malloc(cap > 0 ? cap : 1);
    CHECK(out != NULL);
    if (aacmm_cobs_decode(data, size, out, cap, &n) == AACMM_OK) {
        uint8_t *enc = (uint8_t *)malloc(AACMM_COBS_MAX_ENCODED(n));
        uint8_t *dec = (uint8_t *)malloc(n > 0 ? n : 1);
        size_t m = 0, k = 0;
        CHECK(enc != NULL && dec != NULL);
        CHECK(n <= size);
        CHECK(aacmm_cobs_encode(out, n, enc, AACMM_COBS_MAX_ENCODED(n), &m) == AACMM_OK);
        CHECK(aacmm_cobs_decode(enc, m, dec, n, &k) == AACMM_OK);
        CHECK(k == n && (n == 0 || memcmp(dec, out, n) == 0));
        free(enc);
        free(dec);
    }
    free(out);
}

static unsigned enc_sample(const aacmm_enc_frame_t *f, unsigned k)
{
    return (unsigned)(f->line[k / 8u] >> (7u - k % 8u)) & 1u;
}

static void fuzz_encoder(const uint8_t *data, size_t size)
{
    aacmm_enc_joint_config_t cfg;
    aacmm_enc_frame_t f;
    uint32_t pos = 0u;
    uint8_t warn = 0u;
    uint8_t fault;
    size_t n;
    if (size < 3u) {
        return;
    }
    cfg.interface = data[0];
    cfg.bits = data[1];
    memset(&f, 0, sizeof f);
    f.n_bits = data[2];
    n = size - 3u < sizeof f.line ? size - 3u : sizeof f.line;
    memcpy(f.line, data + 3, n);
    fault = aacmm_enc_decode(&cfg, &f, &pos, &warn);
    CHECK(fault <= AACMM_ENC_FAULT_MAX && warn <= 1u);
    if (fault != AACMM_ENC_FAULT_NONE) {
        CHECK(pos == 0u && warn == 0u);
        return;
    }
    CHECK(aacmm_enc_config_validate(&cfg) == AACMM_OK);
    CHECK(cfg.bits == 32u || pos < (UINT32_C(1) << cfg.bits));
    if (cfg.interface == AACMM_ENC_BISS_C) {
        unsigned k = 0u;
        unsigned first;
        unsigned i;
        unsigned nb = f.n_bits > AACMM_ENC_FRAME_MAX_BITS ? AACMM_ENC_FRAME_MAX_BITS : f.n_bits;
        while (k < nb && enc_sample(&f, k) == 1u) {
            k++;
        }
        while (k < nb && enc_sample(&f, k) == 0u) {
            k++;
        }
        first = k + 2u; /* the frame stays in place when these flip */
        for (i = first; i < first + cfg.bits + 2u + AACMM_BISS_CRC_BITS; i++) {
            aacmm_enc_frame_t g = f;
            uint32_t p2 = 0u;
            uint8_t w2 = 0u;
            g.line[i / 8u] ^= (uint8_t)(0x80u >> (i % 8u));
            CHECK(aacmm_enc_decode(&cfg, &g, &p2, &w2) == AACMM_ENC_FAULT_CRC);
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size == 0) {
        return 0;
    }
    switch (data[0] % 5u) {
    case 0: fuzz_deframer(data + 1, size - 1); break;
    case 1: fuzz_body(data + 1, size - 1); break;
    case 2: fuzz_isotp(data + 1, size - 1); break;
    case 3: fuzz_cobs(data + 1, size - 1); break;
    default: fuzz_encoder(data + 1, size - 1); break;
    }
    return 0;
}
