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

#endif /* AACMM_BOARD_H */
