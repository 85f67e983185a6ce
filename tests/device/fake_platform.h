/*
 * A fake, in-memory platform for the device tests: a clock the test sets,
 * serial and CAN links as byte / frame buffers with a switchable "driver
 * full", encoders and button the test sets, and storage with a write budget
 * that simulates a power cut after any byte.
 */
#ifndef FAKE_PLATFORM_H
#define FAKE_PLATFORM_H

#include <stddef.h>
#include <stdint.h>

#include "aacmm/device.h"
#include "aacmm/platform.h"

#define FAKE_SERIAL_RX 65536u
#define FAKE_SERIAL_TX (4u * 1024u * 1024u)
#define FAKE_CAN_RX 1024u
#define FAKE_CAN_TX 65536u

typedef struct {
    uint64_t now_us;
    /* serial: the device reads rx[rx_pos..rx_len), writes append to tx */
    uint8_t rx[FAKE_SERIAL_RX];
    size_t rx_pos, rx_len;
    uint8_t tx[FAKE_SERIAL_TX];
    size_t tx_len;
    size_t tx_limit;   /* bytes accepted per serial_write call (SIZE_MAX: all) */
    int serial_error;  /* serial calls return AACMM_ERR_IO */
    /* CAN */
    aacmm_can_frame_t can_rx[FAKE_CAN_RX];
    size_t can_rx_pos, can_rx_len;
    aacmm_can_frame_t can_tx[FAKE_CAN_TX];
    size_t can_tx_len;
    int can_busy;      /* can_send answers AACMM_ERR_BUSY */
    /* encoders and button */
    uint32_t counts[AACMM_JOINTS];
    aacmm_enc_frame_t frames[AACMM_JOINTS_MAX]; /* read_encoder_frames (fake_use_frames) */
    aacmm_status_t encoder_status;
    unsigned encoder_reads;
    uint8_t button; /* button levels, bit i = button i held */
    /* link temperatures (fake_use_temperatures): read_temperatures gives
     * temp[] and temp_valid, or fails with temp_status */
    int16_t temp[AACMM_JOINTS_MAX];
    uint8_t temp_valid;
    aacmm_status_t temp_status;
    unsigned temp_reads;
    /* storage */
    uint8_t storage[AACMM_STORE_BYTES];
    long write_budget; /* bytes still written before the "power cut"; < 0 = unlimited */
    int read_error;
    unsigned storage_writes;
    /* flash (fake_use_flash): writes only clear bits, storage_erase sets a
     * slot to 0xFF byte by byte; the same write_budget counts erased bytes */
    int flash;
    unsigned storage_erases;
} fake_t;

/* Clean state: time 1 s, everything empty, storage erased (0xFF),
 * unlimited writes, encoders at 0. */
void fake_init(fake_t *f);

/* The platform table: links as asked. */
void fake_platform(fake_t *f, aacmm_platform_t *pf, int serial, int can, int storage, int button);

/* Joints as frames: pf->read_encoder_frames returns f->frames. */
void fake_use_frames(fake_t *f, aacmm_platform_t *pf);

/* The platform reads link temperatures (pf->read_temperatures): every link
 * at 20.00 degC and valid until the test changes f->temp / temp_valid /
 * temp_status. */
void fake_use_temperatures(fake_t *f, aacmm_platform_t *pf);

/* Storage behaves as NOR flash with an erase function (see fake_t.flash). */
void fake_use_flash(fake_t *f, aacmm_platform_t *pf);

#endif
