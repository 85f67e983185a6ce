/*
 * Link-protocol codec benchmark (host CPU): one JSON object per line.
 * Measures encode (message -> serial frame) and receive (deframe + decode)
 * for a plain sample and a sample with Jacobian, and ISO-TP send+receive.
 */
#define _POSIX_C_SOURCE 199309L
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "aacmm/frame.h"
#include "aacmm/isotp.h"
#include "aacmm/proto.h"

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static volatile uint32_t sink;

static void bench_serial(const char *what, const aacmm_msg_t *msg, long n)
{
    static uint8_t scratch[AACMM_PROTO_MAX_BODY], wire[AACMM_FRAME_MAX_WIRE];
    static aacmm_deframer_t d;
    size_t wl = 0;
    long i;
    double t0, t_enc, t_dec;
    aacmm_msg_t out;
    t0 = now_s();
    for (i = 0; i < n; i++) {
        (void)aacmm_msg_encode_frame(msg, scratch, sizeof scratch, wire, sizeof wire, &wl);
        sink += wire[wl / 2];
    }
    t_enc = now_s() - t0;
    aacmm_deframer_init(&d);
    t0 = now_s();
    for (i = 0; i < n; i++) {
        const uint8_t *b = NULL;
        size_t bl = 0;
        (void)aacmm_deframer_feed(&d, wire, wl, &b, &bl);
        if (b != NULL && aacmm_msg_decode(b, bl, &out) == AACMM_OK) {
            sink += out.seq;
        }
    }
    t_dec = now_s() - t0;
    printf("{\"bench\": \"protocol\", \"what\": \"serial %s\", \"wire_bytes\": %zu, "
           "\"encode_ns\": %.1f, \"receive_ns\": %.1f, \"frames_ok\": %u}\n",
           what, wl, t_enc * 1e9 / (double)n, t_dec * 1e9 / (double)n, (unsigned)d.stats.frames_ok);
}

static void bench_isotp(long n)
{
    static aacmm_isotp_t a, b;
    static uint8_t arx[512], atx[512], brx[512], btx[512], msg[356];
    aacmm_isotp_config_t ca = {0x605, 0x685, arx, sizeof arx, atx, sizeof atx, 0, 0, 0xCC, 10, 1000};
    aacmm_isotp_config_t cb = {0x685, 0x605, brx, sizeof brx, btx, sizeof btx, 0, 0, 0xCC, 10, 1000};
    long i;
    size_t frames = 0;
    double t0, t;
    memset(msg, 0x5A, sizeof msg);
    (void)aacmm_isotp_init(&a, &ca);
    (void)aacmm_isotp_init(&b, &cb);
    t0 = now_s();
    for (i = 0; i < n; i++) {
        aacmm_can_frame_t f;
        const uint8_t *m = NULL;
        size_t ml = 0;
        int moved = 1;
        (void)aacmm_isotp_send(&a, msg, sizeof msg, 0);
        while (moved) {
            moved = 0;
            while (aacmm_isotp_poll(&a, 0, &f)) {
                aacmm_isotp_on_frame(&b, &f, 0);
                frames++;
                moved = 1;
            }
            while (aacmm_isotp_poll(&b, 0, &f)) {
                aacmm_isotp_on_frame(&a, &f, 0);
                frames++;
                moved = 1;
            }
        }
        if (aacmm_isotp_receive(&b, &m, &ml)) {
            sink += m[ml - 1];
        }
    }
    t = now_s() - t0;
    printf("{\"bench\": \"protocol\", \"what\": \"isotp 356-byte message send+receive\", "
           "\"frames_per_message\": %.1f, \"ns_per_message\": %.1f, \"messages_ok\": %u}\n",
           (double)frames / (double)n, t * 1e9 / (double)n, (unsigned)b.stats.rx_messages);
}

int main(void)
{
    aacmm_msg_t m;
    int i;
    memset(&m, 0, sizeof m);
    m.type = AACMM_MSG_SAMPLE_EVT;
    m.seq = 1;
    m.u.sample.seq = 123456;
    m.u.sample.timestamp_us = 987654321u;
    for (i = 0; i < 6; i++) {
        m.u.sample.counts[i] = 0x12345678u * (uint32_t)(i + 1);
    }
    m.u.sample.point_100nm[0] = 12345678;
    m.u.sample.point_100nm[1] = -2345678;
    m.u.sample.point_100nm[2] = 345678;
    m.u.sample.status = AACMM_SAMPLE_POINT_VALID;
    bench_serial("sample (56-byte body)", &m, 200000);
    m.u.sample.content = AACMM_CONTENT_JACOBIAN;
    for (i = 0; i < 75; i++) {
        m.u.sample.jacobian[i] = (float)i * 1.25f - 40.0f;
    }
    bench_serial("sample with Jacobian (356-byte body)", &m, 50000);
    bench_isotp(50000);
    return sink == 0xFFFFFFFFu;
}
