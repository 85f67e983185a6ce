/*
 * The boards' interrupt-driven UART: one receive ring, one transmit ring and
 * their flow rules, written once for every board (uart.c). It implements
 * board.h's board_uart_read, board_uart_write, board_uart_write_blocking and
 * board_idle. A board differs only in its register access:
 *
 *   firmware/boards/<board>/uart_hw.h   the UART's registers and five static
 *       inline functions that uart.c is compiled with on that board's build:
 *         void    uart_hw_send(uint8_t b)  write b to the idle transmitter;
 *                                          its "sent" interrupt must follow
 *         int     uart_hw_rx_ready(void)   a received byte waits in the UART
 *         uint8_t uart_hw_rx_take(void)    take it (acknowledging it)
 *         void    uart_hw_rx_pause(void)   receive interrupt off; received
 *                                          bytes stay in the UART
 *         void    uart_hw_rx_resume(void)  receive interrupt on again, so that
 *                                          a byte held in the UART is taken
 *   firmware/boards/<board>/board.c     uart_init (pins, baud rate, interrupt
 *       enables) and the UART interrupt handlers, which acknowledge the
 *       interrupt and call the board_uart_isr_* functions below.
 *
 * Ownership: uart.c owns both rings (static storage, no heap) and the
 * counters; nothing else touches them. The rings' sizes are compile-time
 * constants, each a power of two from 2 to 2^31 (a build with another value
 * fails): BOARD_UART_RX_BYTES (default 1024) and BOARD_UART_TX_BYTES
 * (default 2048), set per board in mk/boards.mk (the micro:bit: 256 each).
 *
 * Sides: the main loop consumes the RX ring and produces into the TX ring
 * (board_uart_read, board_uart_write); the UART interrupt produces into the RX
 * ring and consumes the TX ring (board_uart_isr_*). Each ring index and each
 * counter has one writer, so neither side takes a lock, except that
 * board_uart_write starts an idle transmitter with interrupts masked (a few
 * instructions). The main-loop functions must not be called from an
 * interrupt handler; the board_uart_isr_* functions only from the UART's
 * interrupt handlers, which must not preempt one another (one priority).
 *
 * Flow: a full RX ring pauses reception (uart_hw_rx_pause): bytes stay in the
 * UART, which on real hardware then overruns and under QEMU holds the sender
 * back; board_uart_read resumes it once it has made room. A full TX ring
 * makes board_uart_write take fewer bytes than asked: the caller keeps the
 * rest (the device's serial queue does). Cost: O(1) per byte, O(len) per
 * call; nothing blocks but board_uart_write_blocking.
 */
#ifndef AACMM_BOARD_UART_H
#define AACMM_BOARD_UART_H

#include <stdint.h>

/* ---- what the board's UART interrupt handlers call ---- */

/* Bytes received: take them from the UART into the RX ring while it has
 * room. When it is full, reception pauses (counted in rx_pauses) and the
 * rest stay in the UART until board_uart_read makes room. */
void board_uart_isr_rx(void);

/* The UART reported a line error (overrun, framing, parity, break): counted
 * in rx_errors. The handler clears the error itself. */
void board_uart_isr_rx_error(void);

/* The transmitter has sent its byte: send the next one, or mark the
 * transmitter idle when the TX ring is empty. */
void board_uart_isr_tx_done(void);

/* ---- what it counts ---- */

/* Counts since board_init, never cleared, each wrapping modulo 2^32. */
typedef struct {
    uint32_t rx_bytes;      /* bytes board_uart_read handed to its callers */
    uint32_t rx_pauses;     /* times the RX ring filled and reception paused */
    uint32_t rx_errors;     /* line errors the UART reported */
    uint32_t tx_bytes;      /* bytes board_uart_write (and _blocking) took */
    uint32_t tx_peak_bytes; /* the most bytes waiting in the TX ring after a
                             * write (BOARD_UART_TX_BYTES: it has been full) */
} board_uart_counts_t;

/* Copy the counters into *out (each word read whole; the set is not taken
 * at one instant while the interrupt runs). Main loop. */
void board_uart_counts(board_uart_counts_t *out);

#endif /* AACMM_BOARD_UART_H */
