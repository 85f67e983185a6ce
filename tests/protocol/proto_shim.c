/*
 * Test-only shared library: a flat, byte-oriented face of the C codec for the
 * pytest interop tests (tests/host/test_protocol_interop.py, loaded with
 * ctypes). Not part of the firmware. The ISO-TP functions drive one static
 * endpoint.
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "aacmm/frame.h"
#include "aacmm/isotp.h"
#include "aacmm/proto.h"
#include "aacmm/proto_can.h"

int shim_decode(const uint8_t *body, size_t len);
int shim_reencode(const uint8_t *body, size_t len, uint8_t *out, size_t cap, size_t *out_len);
int shim_frame(const uint8_t *body, size_t len, uint8_t *out, size_t cap, size_t *out_len);
size_t shim_deframe(const uint8_t *wire, size_t len, uint8_t *bodies, size_t cap, size_t *lens,
                    size_t max, uint32_t *stats);
int shim_can_sample(const uint8_t *body, size_t len, uint8_t node, uint32_t *ids, uint8_t *data);
int shim_param_crc(const uint8_t *payload, size_t len, uint32_t *crc);
int shim_isotp_init(uint32_t tx_id, uint32_t rx_id, uint8_t bs, uint8_t stmin, size_t rx_cap);
void shim_isotp_on_frame(uint32_t id, uint8_t dlc, const uint8_t *data, uint32_t now);
int shim_isotp_poll(uint32_t now, uint32_t *id, uint8_t *dlc, uint8_t *data);
int shim_isotp_send(const uint8_t *data, size_t len, uint32_t now);
int shim_isotp_receive(uint8_t *out, size_t cap, size_t *len);
int shim_isotp_tx_result(void);
void shim_isotp_stats(uint32_t *out11);

int shim_decode(const uint8_t *body, size_t len)
{
    aacmm_msg_t m;
    return (int)aacmm_msg_decode(body, len, &m);
}

int shim_reencode(const uint8_t *body, size_t len, uint8_t *out, size_t cap, size_t *out_len)
{
    aacmm_msg_t m;
    aacmm_status_t st = aacmm_msg_decode(body, len, &m);
    *out_len = 0;
    if (st != AACMM_OK) {
        return (int)st;
    }
    return (int)aacmm_msg_encode(&m, out, cap, out_len);
}

int shim_frame(const uint8_t *body, size_t len, uint8_t *out, size_t cap, size_t *out_len)
{
    return (int)aacmm_frame_encode(body, len, out, cap, out_len);
}

size_t shim_deframe(const uint8_t *wire, size_t len, uint8_t *bodies, size_t cap, size_t *lens,
                    size_t max, uint32_t *stats)
{
    static aacmm_deframer_t d;
    size_t off = 0, count = 0, used = 0;
    aacmm_deframer_init(&d);
    while (off < len) {
        const uint8_t *b = NULL;
        size_t bl = 0;
        off += aacmm_deframer_feed(&d, wire + off, len - off, &b, &bl);
        if (b != NULL && count < max && used + bl <= cap) {
            memcpy(bodies + used, b, bl);
            used += bl;
            lens[count++] = bl;
        }
    }
    stats[0] = d.stats.frames_ok;
    stats[1] = d.stats.crc_errors;
    stats[2] = d.stats.cobs_errors;
    stats[3] = d.stats.oversize;
    stats[4] = d.stats.runts;
    stats[5] = d.stats.bytes_dropped;
    return count;
}

/* The sample frames of a sample body: returns their number (5..7) or a
 * negative status. ids and data hold AACMM_CAN_SAMPLE_FRAMES_MAX entries. */
int shim_can_sample(const uint8_t *body, size_t len, uint8_t node, uint32_t *ids, uint8_t *data)
{
    aacmm_msg_t m;
    aacmm_can_frame_t f[AACMM_CAN_SAMPLE_FRAMES_MAX];
    aacmm_status_t st = aacmm_msg_decode(body, len, &m);
    size_t i, n = 0;
    if (st != AACMM_OK) {
        return (int)st;
    }
    if (m.type != AACMM_MSG_SAMPLE_EVT && m.type != AACMM_MSG_MEASURE_RSP) {
        return (int)AACMM_ERR_UNKNOWN_TYPE;
    }
    st = aacmm_can_sample_encode(&m.u.sample, node, f, &n);
    if (st != AACMM_OK) {
        return (int)st;
    }
    for (i = 0; i < n; i++) {
        ids[i] = f[i].id;
        memcpy(data + 8 * i, f[i].data, 8);
    }
    return (int)n;
}

int shim_param_crc(const uint8_t *payload, size_t len, uint32_t *crc)
{
    aacmm_param_set_t p;
    aacmm_status_t st = aacmm_param_set_decode(payload, len, &p);
    if (st != AACMM_OK) {
        return (int)st;
    }
    return (int)aacmm_param_set_crc32(&p, crc);
}

static aacmm_isotp_t g_tp;
static uint8_t g_rx[AACMM_ISOTP_MAX_LEN];
static uint8_t g_tx[AACMM_ISOTP_MAX_LEN];

int shim_isotp_init(uint32_t tx_id, uint32_t rx_id, uint8_t bs, uint8_t stmin, size_t rx_cap)
{
    aacmm_isotp_config_t cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.tx_id = tx_id;
    cfg.rx_id = rx_id;
    cfg.rx_buf = g_rx;
    cfg.rx_cap = rx_cap;
    cfg.tx_buf = g_tx;
    cfg.tx_cap = sizeof g_tx;
    cfg.block_size = bs;
    cfg.st_min = stmin;
    cfg.padding = 0xCC;
    cfg.max_wait = AACMM_ISOTP_DEFAULT_MAX_WAIT;
    cfg.timeout_ms = 10000u; /* generous: the test host may be heavily loaded */
    return (int)aacmm_isotp_init(&g_tp, &cfg);
}

void shim_isotp_on_frame(uint32_t id, uint8_t dlc, const uint8_t *data, uint32_t now)
{
    aacmm_can_frame_t f;
    memset(&f, 0, sizeof f);
    f.id = id;
    f.dlc = dlc;
    memcpy(f.data, data, dlc <= 8u ? dlc : 8u);
    aacmm_isotp_on_frame(&g_tp, &f, now);
}

int shim_isotp_poll(uint32_t now, uint32_t *id, uint8_t *dlc, uint8_t *data)
{
    aacmm_can_frame_t f;
    if (!aacmm_isotp_poll(&g_tp, now, &f)) {
        return 0;
    }
    *id = f.id;
    *dlc = f.dlc;
    memcpy(data, f.data, 8);
    return 1;
}

int shim_isotp_send(const uint8_t *data, size_t len, uint32_t now)
{
    return (int)aacmm_isotp_send(&g_tp, data, len, now);
}

int shim_isotp_receive(uint8_t *out, size_t cap, size_t *len)
{
    const uint8_t *m = NULL;
    size_t n = 0;
    if (!aacmm_isotp_receive(&g_tp, &m, &n) || n > cap) {
        *len = 0;
        return 0;
    }
    memcpy(out, m, n);
    *len = n;
    return 1;
}

int shim_isotp_tx_result(void)
{
    return (int)aacmm_isotp_tx_result(&g_tp);
}

void shim_isotp_stats(uint32_t *out11)
{
    const aacmm_isotp_stats_t *s = &g_tp.stats;
    out11[0] = s->rx_messages;
    out11[1] = s->rx_bad_frames;
    out11[2] = s->rx_sequence_errors;
    out11[3] = s->rx_timeouts;
    out11[4] = s->rx_overflows;
    out11[5] = s->rx_interrupted;
    out11[6] = s->rx_unexpected;
    out11[7] = s->tx_messages;
    out11[8] = s->tx_timeouts;
    out11[9] = s->tx_refused;
    out11[10] = s->tx_aborted;
}
