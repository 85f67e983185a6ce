/*
 * The device application on a board: the platform table (aacmm/platform.h)
 * filled from the board layer (board.h), the reset record, the watchdog and
 * the main loop. The same file serves every board; the board's kinematics
 * backend is chosen at build time (mk/boards.mk: float core on the M4F,
 * -DAACMM_DEVICE_KIN_FIXED on the M0).
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
 *   temperatures    the board's sensor (board_temp_probe at start-up; its one
 *                   reading for every link), none if it did not answer
 *   storage         the board's: two flash pages on the micro:bit (NVMC),
 *                   RAM kept across resets on the MPS2 (board.c)
 *
 * Reset record: a few words of RAM that start-up does not clear, guarded by
 * a magic and its complement, so a power-up (RAM holds anything) is told
 * from a reset. It counts the starts since power-up and keeps the cause of a
 * reset the firmware saw coming: a CPU fault (HardFault handler, with the
 * faulting program counter), the watchdog's early warning, its own reset
 * requests. Otherwise the board's reset register says what happened.
 *
 * Main loop: poll the device, feed the watchdog, then sleep (board_idle:
 * WFI, woken by the UART and by the board's 1 ms tick) unless the device is
 * due again, bytes are waiting or output is queued.
 *
 * BOARD_TEST_HOOKS (the fw-test.elf images only): a word at board_test_hook,
 * written by the test through QEMU's loader device, asks for a misbehaviour
 * once per value: cut saves at chosen flash steps, hang the main loop,
 * fault, or corrupt encoder frames (see test_hooks below).
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "aacmm/device.h"
#include "aacmm_sim.h"
#include "board.h"
#include "board_startup.h"

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
#ifndef BOARD_WATCHDOG_MS
#define BOARD_WATCHDOG_MS 2000u
#endif

static aacmm_device_t dev;
static uint8_t serial_txq[BOARD_SERIAL_TXQ_BYTES];
static aacmm_sim_t sim;
static aacmm_sim_encoders_t encoders;

/* ---- reset record ------------------------------------------------------- */

#define RECORD_MAGIC 0x52535431u /* "RST1" */
#define CAUSE_WATCHDOG_WARNED 0x80u /* early warning seen; cleared if fed again */

typedef struct {
    uint32_t magic;
    uint32_t magic_inv;
    uint32_t boot_count;
    uint32_t cause;    /* AACMM_RESET_* the firmware recorded before a reset */
    uint32_t fault_pc;
    uint32_t hook_done; /* test hooks: the hook value already acted on */
    uint32_t hook_saves; /* test hooks: saves seen under a cut hook */
} reset_record_t;

__attribute__((section(".noinit"))) static volatile reset_record_t rec;

static void record_cause(uint32_t cause, uint32_t pc)
{
    rec.cause = cause;
    rec.fault_pc = pc;
}

/* The cause of this start, and the record readied for the next one. */
static uint8_t start_record(uint32_t reg, uint32_t *fault_pc)
{
    uint8_t cause;
    *fault_pc = 0u;
    if (rec.magic != RECORD_MAGIC || rec.magic_inv != ~RECORD_MAGIC) {
        rec.magic = RECORD_MAGIC;
        rec.magic_inv = ~RECORD_MAGIC;
        rec.boot_count = 1u;
        rec.hook_done = 0u;
        rec.hook_saves = 0u;
        cause = (uint8_t)AACMM_RESET_POWER_ON;
    } else {
        rec.boot_count = rec.boot_count + 1u;
        if (rec.cause == CAUSE_WATCHDOG_WARNED) {
            cause = (uint8_t)AACMM_RESET_WATCHDOG;
        } else if (rec.cause != 0u && rec.cause <= AACMM_RESET_CAUSE_MAX) {
            cause = (uint8_t)rec.cause;
            *fault_pc = rec.fault_pc;
        } else {
            cause = board_reset_cause(reg);
        }
    }
    record_cause(0u, 0u);
    return cause;
}

/* The watchdog's early warning: the main loop stalled. If it recovers and
 * feeds again the note is withdrawn (board_watchdog_feed below). */
void board_watchdog_warning(void)
{
    record_cause(CAUSE_WATCHDOG_WARNED, 0u);
}

static void feed_watchdog(void)
{
    if (rec.cause == CAUSE_WATCHDOG_WARNED) {
        record_cause(0u, 0u);
    }
    board_watchdog_feed();
}

/* HardFault: note where, then reset. The handler takes the stacked frame
 * (main stack: no thread stack is used) and reads the faulting PC from it. */
void device_fault(const uint32_t *frame);
void device_fault(const uint32_t *frame)
{
    record_cause(AACMM_RESET_FAULT, frame[6]);
    board_system_reset();
}

__attribute__((naked)) void HardFault_Handler(void)
{
    __asm__ volatile("mrs r0, msp\n\t"
                     "bl device_fault\n\t");
}

/* ---- test hooks (fw-test.elf) --------------------------------------------- */

#ifdef BOARD_TEST_HOOKS
/* The hook word: action in bits 31..28, argument below.
 *   1: cut saves: argument = seed (bits 27..8), count (bits 7..0): of the
 *      saves numbered s = 0, 1, 2, ..., the odd ones (s = 2n + 1, n <
 *      count) are cut at flash step (seed + 37 n) mod 75 (75 steps = the
 *      erase and the 74 words of a record: 75 cuts hit every step once), the
 *      word at the cut left partly programmed, then the chip resets; the even
 *      ones complete, so the cuts hit both slots in turn
 *   2: hang the main loop, asleep and not feeding the watchdog, after
 *      argument ms
 *   3: fault (an undefined instruction) after argument ms
 *   4: corrupt one encoder frame in `argument`
 * Each value acts once (the record remembers it across the resets it causes). */
__attribute__((section(".noinit.hook"), used)) volatile uint32_t board_test_hook;

static uint32_t hook_value;
static int32_t hook_cut_at = -1;
static uint32_t hook_mask;

static uint32_t hook_action(void)
{
    return hook_value >> 28;
}

static uint32_t hook_arg(void)
{
    return hook_value & 0x0FFFFFFFu;
}

static void hooks_start(void)
{
    hook_value = board_test_hook;
    if (hook_value != rec.hook_done) { /* a new request */
        rec.hook_done = hook_value;
        rec.hook_saves = 0u;
    } else if (hook_action() == 2u || hook_action() == 3u) {
        hook_value = 0u; /* done already: once per value */
    }
}

int board_flash_hook(uint32_t step, uint32_t *word)
{
    if (hook_action() != 1u) {
        return 0;
    }
    if (step == 0u) { /* a save begins */
        uint32_t s = rec.hook_saves;
        uint32_t n = s / 2u;
        uint32_t seed = (hook_arg() >> 8) & 0xFFFFFu;
        uint32_t count = hook_arg() & 0xFFu;
        rec.hook_saves = s + 1u;
        hook_cut_at = (s % 2u == 1u && n < count) ? (int32_t)((seed + 37u * n) % 75u) : -1;
        hook_mask = (seed * 2654435761u) ^ (n * 40503u);
    }
    if ((int32_t)step != hook_cut_at) {
        return 0;
    }
    if (word != NULL) {
        *word |= hook_mask; /* the bits it sets stay erased: a cut word */
    }
    record_cause(AACMM_RESET_SOFTWARE, 0u);
    return 1;
}

__attribute__((noinline, used)) void board_test_fault(void);
__attribute__((noinline, used)) void board_test_fault(void)
{
    __asm__ volatile(".short 0xde00" ::: "memory"); /* UDF #0: undefined instruction */
}

static void hooks_poll(void)
{
    uint32_t action = hook_action();
    if ((action != 2u && action != 3u) || board_time_us() < (uint64_t)hook_arg() * 1000u) {
        return;
    }
    if (action == 2u) {
        for (;;) {
            /* asleep: interrupts run, nothing reads the UART or feeds the watchdog */
            __asm__ volatile("wfi" ::: "memory");
        }
    }
    board_test_fault();
}

static uint32_t hooks_fault_every(void)
{
    return hook_action() == 4u ? hook_arg() : BOARD_ENC_FAULT_EVERY;
}
#else
#define hooks_start() ((void)0)
#define hooks_poll() ((void)0)
#define hooks_fault_every() (BOARD_ENC_FAULT_EVERY)
#endif

/* ---- platform table ------------------------------------------------------- */

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
static aacmm_status_t pf_read_encoder_frames(void *ctx, aacmm_enc_frame_t frames[AACMM_JOINTS_MAX])
{
    uint32_t counts[AACMM_JOINTS_MAX];
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

/* One sensor on the boards: its reading stands for every link. */
static aacmm_status_t pf_read_temperatures(void *ctx, int16_t temp[AACMM_JOINTS_MAX],
                                           uint8_t *valid)
{
    int16_t t = 0;
    int j;
    (void)ctx;
    if (board_temp_read(&t) != 0) {
        return AACMM_ERR_IO; /* no conversion within the timeout */
    }
    for (j = 0; j < AACMM_JOINTS_MAX; j++) {
        temp[j] = t;
    }
    *valid = (uint8_t)((1u << AACMM_JOINTS_MAX) - 1u);
    return AACMM_OK;
}

static aacmm_status_t pf_storage_read(void *ctx, uint32_t offset, uint8_t *buf, size_t len)
{
    (void)ctx;
    return board_storage_read(offset, buf, len) == 0 ? AACMM_OK : AACMM_ERR_IO;
}

static aacmm_status_t pf_storage_write(void *ctx, uint32_t offset, const uint8_t *data,
                                       size_t len)
{
    (void)ctx;
    return board_storage_write(offset, data, len) == 0 ? AACMM_OK : AACMM_ERR_IO;
}

static aacmm_status_t pf_storage_erase(void *ctx, uint32_t offset, size_t len)
{
    (void)ctx;
    return board_storage_erase(offset, len) == 0 ? AACMM_OK : AACMM_ERR_IO;
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
    uint32_t fault_pc = 0u;
    uint8_t cause;
    int j;

    board_init();
    cause = start_record(board_reset_register(), &fault_pc);
    hooks_start();

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
    for (j = 0; j < AACMM_JOINTS_MAX; j++) {
        ec.joint[j].interface = (uint8_t)AACMM_ENC_BISS_C;
        ec.joint[j].bits = 32u;
    }
    ec.fault_every = hooks_fault_every();
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
    pf.read_temperatures = board_temp_probe() ? pf_read_temperatures : NULL;
    pf.storage_read = pf_storage_read;
    pf.storage_write = pf_storage_write;
    pf.storage_erase = board_storage_has_erase ? pf_storage_erase : NULL;
    pf.storage_bytes = AACMM_STORE_BYTES;
    pf.storage_kind = board_storage_kind;
    pf.storage_flags = board_storage_flags;

    memset(&dc, 0, sizeof dc);
    dc.serial_number = BOARD_SERIAL_NUMBER;
    dc.can_node_id = 1u;
    dc.defaults = NULL; /* the paper's arm, 2^32-count encoders: as the simulated arm */
    dc.serial_txq = serial_txq;
    dc.serial_txq_bytes = sizeof serial_txq;
    dc.reset_cause = cause;
    dc.reset_raw = board_reset_register();
    dc.fault_pc = fault_pc;
    dc.boot_count = rec.boot_count;
    for (j = 0; j < AACMM_JOINTS_MAX; j++) {
        dc.encoders[j] = ec.joint[j];
    }
    dc.watchdog_ms = (uint16_t)board_watchdog_start(BOARD_WATCHDOG_MS);
    if (aacmm_device_init(&dev, &dc, &pf) != AACMM_OK) {
        fail();
    }

    for (;;) {
        (void)aacmm_device_poll(&dev);
        feed_watchdog();
        hooks_poll();
        if (board_time_us() < aacmm_device_next_deadline_us(&dev) &&
            aacmm_device_serial_pending(&dev) == 0u) {
            board_idle();
        }
    }
}
