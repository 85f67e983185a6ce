/*
 * The board layer under the device application and the self-test: what each
 * port in firmware/boards/<board>/ provides. The device application itself
 * only sees the platform table (aacmm/platform.h); firmware/boards/common/
 * fills that table from these functions.
 *
 * Rules: nothing here blocks except board_uart_write_blocking (used only by
 * the boot banner and the self-test); the UART functions are safe to call from
 * the main loop while the UART interrupt runs.
 */
#ifndef AACMM_BOARD_H
#define AACMM_BOARD_H

#include <stddef.h>
#include <stdint.h>

/* Clocks, caches, the UART (115200 8N1 on real hardware) and the time base.
 * Called once from main before anything else. */
void board_init(void);

/* Board name, e.g. "mps2-an386". */
extern const char board_name[];

/* ---- UART (interrupt-driven ring buffers) ---- */

/* Copy up to cap received bytes into buf; returns how many (0 if none). */
size_t board_uart_read(uint8_t *buf, size_t cap);
/* Queue up to len bytes for transmission; returns how many were taken. */
size_t board_uart_write(const uint8_t *data, size_t len);
/* Queue all len bytes, waiting for room; for banners and diagnostics. */
void board_uart_write_blocking(const uint8_t *data, size_t len);

/* ---- time ---- */

/* Monotonic microseconds since board_init. */
uint64_t board_time_us(void);

/* A free-running tick counter of the board's benchmark clock (extended to 64
 * bits across the hardware counter's wrap), and the clock's frequency. Under
 * QEMU with -icount shift=0 one tick is BOARD_NS_PER_TICK instructions. */
uint64_t board_ticks(void);
extern const uint32_t board_tick_hz;

/* Stop the core until the next interrupt (the main loop's idle). */
void board_idle(void);

/* ---- reset, watchdog ---- */

/* The board's reset-reason register as it was at start-up (read once by
 * board_init, then cleared on the chip so the next reset starts afresh);
 * 0 on a board without one. */
uint32_t board_reset_register(void);

/* The reset cause (AACMM_RESET_*) a register value says, or
 * AACMM_RESET_UNKNOWN when it says nothing. */
uint8_t board_reset_cause(uint32_t reg);

/* Start the watchdog: if the main loop does not call board_watchdog_feed
 * within timeout_ms, the board resets. Returns the timeout in force (0: the
 * board has none). Once started it cannot be stopped. */
uint32_t board_watchdog_start(uint32_t timeout_ms);
void board_watchdog_feed(void);

/* Called from the watchdog's early-warning interrupt, shortly before the
 * watchdog resets the board (weak; the default does nothing). */
void board_watchdog_warning(void);

/* Reset the whole chip now (SYSRESETREQ). */
void board_system_reset(void) __attribute__((noreturn));

/* ---- temperature sensor ---- */

/* Look for the board's temperature sensor once, at start-up: start a
 * conversion and wait at most BOARD_TEMP_PROBE_US for it. 1 when it
 * answered (board_temp_read then serves readings), 0 when the board has no
 * sensor or it did not answer (the device then has no read_temperatures). */
int board_temp_probe(void);

/* The latest completed conversion in 0.01 degC into *centi, without
 * blocking: takes a conversion that completed since the last call and
 * starts the next one. 0, or -1 when no conversion completed within
 * BOARD_TEMP_TIMEOUT_US (a sensor that stopped answering) or the board has
 * none. */
int board_temp_read(int16_t *centi);

#define BOARD_TEMP_PROBE_US 10000u    /* start-up wait for the first conversion */
#define BOARD_TEMP_TIMEOUT_US 500000u /* a reading older than this is not valid */

/* ---- parameter storage ---- */

/* AACMM_STORE_BYTES (1 KiB) of storage addressed from 0; bytes 0..511 (slot
 * 0) and 512..1023 (slot 1) each in a flash page of their own where the
 * board has flash. board_storage_kind / _flags are AACMM_STORAGE_KIND_* and
 * AACMM_STORAGE_PERSISTENT. board_storage_erase is NULL-able: boards whose
 * store needs no erase (RAM) set board_storage_has_erase to 0.
 * Writes take word-aligned offsets on flash (the record layout is). */
extern const uint8_t board_storage_kind;
extern const uint8_t board_storage_flags;
extern const uint8_t board_storage_has_erase;
int board_storage_read(uint32_t offset, uint8_t *buf, size_t len);
int board_storage_write(uint32_t offset, const uint8_t *data, size_t len);
int board_storage_erase(uint32_t offset, size_t len);

/* Flash test hook (weak; the default returns 0): called before each flash
 * operation of a save, step 0 = the page erase, 1.. = the words written.
 * *word is the word about to be written (NULL for the erase); the hook may
 * change it (bits it sets to 1 stay erased: a partly programmed word). A
 * non-zero return resets the chip after this operation ("power cut"). */
int board_flash_hook(uint32_t step, uint32_t *word);

#endif /* AACMM_BOARD_H */
