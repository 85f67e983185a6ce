/*
 * The device application on a board: the platform table (aacmm/platform.h)
 * filled from the board layer (board.h), and the main loop. The same file
 * serves every board; the board's kinematics backend is chosen at build time
 * (mk/boards.mk: float core on the M4F, -DAACMM_DEVICE_KIN_FIXED on the M0).
 *
 *   time_us         board_time_us (SysTick on mps2, TIMER0 on the micro:bit)
 *   serial link     the board's interrupt-driven UART rings
 *   CAN link        none
 *   encoders        BiSS-C frames (32-bit position) from the simulated
 *                   encoders, carrying the simulated arm shared with the
 *                   POSIX simulator (firmware/src/sim: smooth random walk,
 *                   2^32 counts/turn) at the board's clock; the device
 *                   decodes them (BOARD_ENC_FAULT_EVERY corrupts some)
 *   button          the simulated arm's (off unless BOARD_BUTTON_PERIOD_US)
 *   storage         AACMM_STORE_BYTES of RAM in .noinit: survives a warm
 *                   reset, reads as erased flash (0xFF) after power-up
 *
 * Main loop: poll the device, then sleep (board_idle: WFI, woken by the UART
 * and by the board's 1 ms tick) unless the device is due again, bytes are
 * waiting or output is queued.
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "aacmm/device.h"
#include "aacmm_sim.h"
#include "board.h"

#ifndef BOARD_SERIAL_TXQ_BYTES
#define BOARD_SERIAL_TXQ_BYTES 4096u
#endif
#ifndef BOARD_SERIAL_NUMBER
#define BOARD_SERIAL_NUMBER 0x0B0A4D00u
#endif
#ifndef BOARD_BUTTON_PERIOD_US
#define BOARD_BUTTON_PERIOD_US 0u
#endif
#ifndef BOARD_SIM_SEED
#define BOARD_SIM_SEED 1u
#endif

#ifndef BOARD_ENC_FAULT_EVERY
#define BOARD_ENC_FAULT_EVERY 0u
#endif

static aacmm_device_t dev;
static uint8_t serial_txq[BOARD_SERIAL_TXQ_BYTES];
static aacmm_sim_t sim;
static aacmm_sim_encoders_t encoders;

/* Parameter storage: RAM that start-up code does not clear. */
#define STORAGE_GUARD 0x53544F52u /* "STOR" */
__attribute__((section(".noinit"))) static uint8_t storage[AACMM_STORE_BYTES];
__attribute__((section(".noinit"))) static uint32_t storage_guard;

static uint64_t pf_time_us(void *ctx)
{
    (void)ctx;
    return board_time_us();
}

static aacmm_status_t pf_serial_read(void *ctx, uint8_t *buf, size_t cap, size_t *got)
{
    (void)ctx;
    *got = board_uart_read(buf, cap);
    return AACMM_OK;
}

static aacmm_status_t pf_serial_write(void *ctx, const uint8_t *data, size_t len,
                                      size_t *accepted)
{
    (void)ctx;
    *accepted = board_uart_write(data, len);
    return AACMM_OK;
}

/* The joints: the simulated arm's counts go out of the simulated BiSS-C
 * encoders frame by frame, clock by clock, and the device decodes them as it
 * would a real encoder's frames. */
static aacmm_status_t pf_read_encoder_frames(void *ctx, aacmm_enc_frame_t frames[AACMM_JOINTS])
{
    uint32_t counts[AACMM_JOINTS];
    (void)ctx;
    if (aacmm_sim_read(&sim, board_time_us(), counts) != AACMM_OK ||
        aacmm_sim_encoders_frames(&encoders, counts, frames) != AACMM_OK) {
        return AACMM_ERR_IO;
    }
    return AACMM_OK;
}

static aacmm_status_t pf_read_buttons(void *ctx, uint8_t *pressed)
{
    (void)ctx;
    /* One button on the boards: the capture button (bit 0). */
    *pressed = aacmm_sim_button(&sim, board_time_us());
    return AACMM_OK;
}

static aacmm_status_t pf_storage_read(void *ctx, uint32_t offset, uint8_t *buf, size_t len)
{
    (void)ctx;
    if (offset > sizeof storage || len > sizeof storage - offset) {
        return AACMM_ERR_IO;
    }
    memcpy(buf, &storage[offset], len);
    return AACMM_OK;
}

static aacmm_status_t pf_storage_write(void *ctx, uint32_t offset, const uint8_t *data,
                                       size_t len)
{
    (void)ctx;
    if (offset > sizeof storage || len > sizeof storage - offset) {
        return AACMM_ERR_IO;
    }
    memcpy(&storage[offset], data, len);
    return AACMM_OK;
}

static void fail(void)
{
    static const char msg[] = "aacmm: device set-up failed\r\n";
    board_uart_write_blocking((const uint8_t *)msg, sizeof msg - 1u);
    for (;;) {
        board_idle();
    }
}

int main(void)
{
    aacmm_platform_t pf;
    aacmm_device_config_t dc;
    aacmm_sim_config_t sc;
    aacmm_sim_encoders_config_t ec;
    int j;

    board_init();
    if (storage_guard != STORAGE_GUARD) {
        memset(storage, 0xFF, sizeof storage); /* power-up: erased */
        storage_guard = STORAGE_GUARD;
    }

    memset(&sc, 0, sizeof sc);
    sc.motion = AACMM_SIM_WALK;
    sc.seed = BOARD_SIM_SEED;
    sc.noise_counts = 0u;
    sc.counts_per_rev = (uint64_t)1 << 32;
    sc.button_period_us = BOARD_BUTTON_PERIOD_US;
    if (aacmm_sim_init(&sim, &sc) != AACMM_OK) {
        fail();
    }
    memset(&ec, 0, sizeof ec);
    for (j = 0; j < AACMM_JOINTS; j++) {
        ec.joint[j].interface = (uint8_t)AACMM_ENC_BISS_C;
        ec.joint[j].bits = 32u;
    }
    ec.fault_every = BOARD_ENC_FAULT_EVERY;
    ec.seed = BOARD_SIM_SEED;
    if (aacmm_sim_encoders_init(&encoders, &ec) != AACMM_OK) {
        fail();
    }

    memset(&pf, 0, sizeof pf);
    pf.time_us = pf_time_us;
    pf.serial_read = pf_serial_read;
    pf.serial_write = pf_serial_write;
    pf.read_encoder_frames = pf_read_encoder_frames;
    pf.read_buttons = pf_read_buttons;
    pf.storage_read = pf_storage_read;
    pf.storage_write = pf_storage_write;
    pf.storage_bytes = AACMM_STORE_BYTES;
    pf.storage_kind = (uint8_t)AACMM_STORAGE_KIND_RAM_RETAINED;
    pf.storage_flags = 0u; /* lost at power-off */

    memset(&dc, 0, sizeof dc);
    dc.serial_number = BOARD_SERIAL_NUMBER;
    dc.can_node_id = 1u;
    dc.defaults = NULL; /* the paper's arm, 2^32-count encoders: as the simulated arm */
    dc.serial_txq = serial_txq;
    dc.serial_txq_bytes = sizeof serial_txq;
    for (j = 0; j < AACMM_JOINTS; j++) {
        dc.encoders[j] = ec.joint[j];
    }
    if (aacmm_device_init(&dev, &dc, &pf) != AACMM_OK) {
        fail();
    }

    for (;;) {
        (void)aacmm_device_poll(&dev);
        if (board_time_us() < aacmm_device_next_deadline_us(&dev) &&
            aacmm_device_serial_pending(&dev) == 0u) {
            board_idle();
        }
    }
}
