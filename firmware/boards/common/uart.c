/*
 * The boards' interrupt-driven UART (contract: uart.h): the RX and TX rings,
 * pausing and resuming reception, starting the transmitter, the counters,
 * and the idle that must not sleep past a received byte. The board's
 * register access comes from its uart_hw.h (inlined here).
 */
#include <stddef.h>
#include <stdint.h>

#include "board.h"
#include "cortexm.h"
#include "ring.h"
#include "uart.h"
#include "uart_hw.h"

#ifndef BOARD_UART_RX_BYTES
#define BOARD_UART_RX_BYTES 1024u
#endif
#ifndef BOARD_UART_TX_BYTES
#define BOARD_UART_TX_BYTES 2048u
#endif
#if BOARD_UART_RX_BYTES < 2u || BOARD_UART_RX_BYTES > 0x80000000u || \
    (BOARD_UART_RX_BYTES & (BOARD_UART_RX_BYTES - 1u)) != 0u
#error "BOARD_UART_RX_BYTES must be a power of two from 2 to 2^31"
#endif
#if BOARD_UART_TX_BYTES < 2u || BOARD_UART_TX_BYTES > 0x80000000u || \
    (BOARD_UART_TX_BYTES & (BOARD_UART_TX_BYTES - 1u)) != 0u
#error "BOARD_UART_TX_BYTES must be a power of two from 2 to 2^31"
#endif

/* One object, so that each function reaches all of it from one address. */
static struct {
    ring_t rx;
    ring_t tx;
    volatile uint32_t rx_paused; /* set by the interrupt, cleared by the main loop */
    volatile uint32_t tx_busy;   /* a byte is in the transmitter */
    /* The counters that the ring indices do not hold already (the indices
     * count the bytes: rx.tail those read, tx.head those written); each
     * field has one writer. */
    volatile uint32_t rx_pauses;
    volatile uint32_t rx_errors;
    uint32_t tx_peak_bytes;
    uint8_t rx_buf[BOARD_UART_RX_BYTES];
    uint8_t tx_buf[BOARD_UART_TX_BYTES];
} u;

/* ---- interrupt side ---- */

void board_uart_isr_rx(void)
{
    while (!u.rx_paused && uart_hw_rx_ready()) {
        if (ring_used(&u.rx) >= BOARD_UART_RX_BYTES) {
            u.rx_paused = 1u;
            u.rx_pauses = u.rx_pauses + 1u;
            uart_hw_rx_pause();
            return;
        }
        (void)ring_put(&u.rx, u.rx_buf, BOARD_UART_RX_BYTES, uart_hw_rx_take());
    }
}

void board_uart_isr_rx_error(void)
{
    u.rx_errors = u.rx_errors + 1u;
}

/* Also board_uart_write's start of an idle transmitter (interrupts masked). */
void board_uart_isr_tx_done(void)
{
    uint8_t b;
    if (ring_get(&u.tx, u.tx_buf, BOARD_UART_TX_BYTES, &b)) {
        uart_hw_send(b);
    } else {
        u.tx_busy = 0u;
    }
}

/* ---- main-loop side ---- */

size_t board_uart_read(uint8_t *buf, size_t cap)
{
    size_t n = 0;
    while (n < cap && ring_get(&u.rx, u.rx_buf, BOARD_UART_RX_BYTES, &buf[n])) {
        n++;
    }
    if (u.rx_paused && n > 0u) {
        u.rx_paused = 0u;
        uart_hw_rx_resume();
    }
    return n;
}

size_t board_uart_write(const uint8_t *data, size_t len)
{
    size_t n = 0;
    uint32_t used;
    uint32_t primask;
    while (n < len && ring_put(&u.tx, u.tx_buf, BOARD_UART_TX_BYTES, data[n])) {
        n++;
    }
    used = ring_used(&u.tx);
    if (used > u.tx_peak_bytes) {
        u.tx_peak_bytes = used;
    }
    /* Start the transmitter if it is idle; its interrupt sends the rest. */
    primask = cortexm_irq_save();
    if (!u.tx_busy) {
        u.tx_busy = 1u;
        board_uart_isr_tx_done(); /* sends the first byte, or finds none */
    }
    cortexm_irq_restore(primask);
    return n;
}

void board_uart_write_blocking(const uint8_t *data, size_t len)
{
    while (len > 0u) {
        size_t n = board_uart_write(data, len);
        data += n;
        len -= n;
    }
}

void board_uart_counts(board_uart_counts_t *out)
{
    out->rx_bytes = u.rx.tail;
    out->rx_pauses = u.rx_pauses;
    out->rx_errors = u.rx_errors;
    out->tx_bytes = u.tx.head;
    out->tx_peak_bytes = u.tx_peak_bytes;
}

/* Sleep until an interrupt, unless received bytes are already waiting (the
 * check and the WFI run with interrupts masked: an interrupt that arrives in
 * between still ends the WFI). */
void board_idle(void)
{
    uint32_t primask = cortexm_irq_save();
    if (ring_used(&u.rx) == 0u) {
        cortexm_wfi();
    }
    cortexm_irq_restore(primask);
}
