/*
 * ARM MPS2 with the AN386 FPGA image (Cortex-M4 with FPU, 25 MHz), as
 * emulated by QEMU's mps2-an386 machine.
 *
 * UART: CMSDK APB UART0 at 0x40004000, RX interrupt IRQ 0, TX interrupt IRQ 1,
 * interrupt driven through two rings. The CMSDK UART holds one received byte
 * (STATE.RXFULL); the RX interrupt moves it into the ring at once.
 * Time: SysTick on the 25 MHz processor clock, reload 2^24 - 1, extended to
 * 64 bits by counting wraps in SysTick_Handler.
 */
#include <stddef.h>
#include <stdint.h>

#include "board.h"
#include "board_startup.h"
#include "cortexm.h"
#include "ring.h"

const char board_name[] = "mps2-an386";

#define CPU_HZ 25000000u
const uint32_t board_tick_hz = CPU_HZ;

/* ---- CMSDK APB UART0 ---- */
#define UART0_BASE 0x40004000u
#define UART_DATA AACMM_REG32(UART0_BASE + 0x00u)
#define UART_STATE AACMM_REG32(UART0_BASE + 0x04u)
#define UART_CTRL AACMM_REG32(UART0_BASE + 0x08u)
#define UART_INTSTATUS AACMM_REG32(UART0_BASE + 0x0Cu) /* write 1 to clear */
#define UART_BAUDDIV AACMM_REG32(UART0_BASE + 0x10u)
#define UART_STATE_TXFULL 0x1u
#define UART_STATE_RXFULL 0x2u
#define UART_CTRL_TXEN 0x1u
#define UART_CTRL_RXEN 0x2u
#define UART_CTRL_TXINTEN 0x4u
#define UART_CTRL_RXINTEN 0x8u
#define UART_INT_TX 0x1u
#define UART_INT_RX 0x2u
#define UART0_RX_IRQ 0u
#define UART0_TX_IRQ 1u
#define BAUD 115200u

#ifndef BOARD_UART_RX_BYTES
#define BOARD_UART_RX_BYTES 1024u
#endif
#ifndef BOARD_UART_TX_BYTES
#define BOARD_UART_TX_BYTES 2048u
#endif

static uint8_t rx_mem[BOARD_UART_RX_BYTES];
static uint8_t tx_mem[BOARD_UART_TX_BYTES];
static ring_t rx_ring = {0u, 0u, rx_mem, BOARD_UART_RX_BYTES - 1u};
static ring_t tx_ring = {0u, 0u, tx_mem, BOARD_UART_TX_BYTES - 1u};
static volatile uint32_t tx_busy;   /* a byte is in the transmitter */
static volatile uint32_t rx_paused; /* ring full: RX interrupt off */

/* RX: the receive register holds one byte; move it to the ring. When the
 * ring is full the byte stays in the UART and the RX interrupt is turned off
 * until board_uart_read makes room (on real hardware the line then overruns;
 * under QEMU the emulated UART holds the sender back, so nothing is lost). */
void IRQ0_Handler(void)
{
    UART_INTSTATUS = UART_INT_RX;
    while (UART_STATE & UART_STATE_RXFULL) {
        if (ring_free(&rx_ring) == 0u) {
            UART_CTRL = UART_CTRL & ~UART_CTRL_RXINTEN;
            rx_paused = 1u;
            return;
        }
        (void)ring_put(&rx_ring, (uint8_t)UART_DATA);
    }
}

/* TX: the previous byte has gone; send the next one or go idle. */
void IRQ1_Handler(void)
{
    uint8_t b;
    UART_INTSTATUS = UART_INT_TX;
    if (ring_get(&tx_ring, &b)) {
        UART_DATA = b;
    } else {
        tx_busy = 0u;
    }
}

size_t board_uart_read(uint8_t *buf, size_t cap)
{
    size_t n = 0;
    while (n < cap && ring_get(&rx_ring, &buf[n])) {
        n++;
    }
    if (rx_paused && n > 0u) {
        /* Room again: take the byte held in the UART via the handler. */
        rx_paused = 0u;
        UART_CTRL = UART_CTRL | UART_CTRL_RXINTEN;
        cortexm_irq_pend(UART0_RX_IRQ);
    }
    return n;
}

size_t board_uart_write(const uint8_t *data, size_t len)
{
    size_t n = 0;
    uint32_t primask;
    while (n < len && ring_put(&tx_ring, data[n])) {
        n++;
    }
    /* Start the transmitter if it is idle; the TX interrupt does the rest. */
    primask = cortexm_irq_save();
    if (!tx_busy) {
        uint8_t b;
        if (ring_get(&tx_ring, &b)) {
            tx_busy = 1u;
            UART_DATA = b;
        }
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

static void uart_init(void)
{
    UART_CTRL = 0u;
    UART_BAUDDIV = CPU_HZ / BAUD;
    UART_INTSTATUS = UART_INT_TX | UART_INT_RX;
    UART_CTRL = UART_CTRL_TXEN | UART_CTRL_RXEN | UART_CTRL_TXINTEN | UART_CTRL_RXINTEN;
    cortexm_irq_enable(UART0_RX_IRQ);
    cortexm_irq_enable(UART0_TX_IRQ);
}

/* ---- SysTick time base ---- */
/* SysTick wraps every millisecond: the wrap interrupt extends the 24-bit
 * counter to 64 bits and wakes the idle loop (board_idle) at least once per
 * millisecond, which paces streaming. */
#define SYSTICK_PERIOD (CPU_HZ / 1000u)
static volatile uint64_t systick_wraps;

void SysTick_Handler(void)
{
    systick_wraps = systick_wraps + 1u;
}

#define SCB_ICSR_PENDSTSET (1u << 26)

uint64_t board_ticks(void)
{
    uint32_t primask = cortexm_irq_save();
    uint64_t wraps = systick_wraps;
    uint32_t val = SYST_CVR;
    if (SCB_ICSR & SCB_ICSR_PENDSTSET) {
        /* Wrapped, handler not run yet: count it, and re-read the counter
         * so that val is certainly from after the wrap. */
        wraps++;
        val = SYST_CVR;
    }
    cortexm_irq_restore(primask);
    return wraps * SYSTICK_PERIOD + (uint64_t)(SYSTICK_PERIOD - 1u - val);
}

uint64_t board_time_us(void)
{
    return board_ticks() / (CPU_HZ / 1000000u);
}

static void systick_init(void)
{
    SYST_CSR = 0u;
    SYST_RVR = SYSTICK_PERIOD - 1u;
    SYST_CVR = 0u;
    SYST_CSR = SYST_CSR_CLKSOURCE | SYST_CSR_TICKINT | SYST_CSR_ENABLE;
}

/* Sleep until an interrupt, unless received bytes are already waiting (the
 * check and the WFI run with interrupts masked: an interrupt that arrives in
 * between still ends the WFI). */
void board_idle(void)
{
    uint32_t primask = cortexm_irq_save();
    if (ring_used(&rx_ring) == 0u) {
        cortexm_wfi();
    }
    cortexm_irq_restore(primask);
}

/* ---- reset cause ---- */
/* The AN386 image as QEMU models it has no reset-reason register (the CMSDK
 * system controller with RSTINFO is not there; measured: reads 0). The
 * device image records the causes it sees coming itself (device_main.c). */
uint32_t board_reset_register(void)
{
    return 0u;
}

uint8_t board_reset_cause(uint32_t reg)
{
    (void)reg;
    return 0u; /* AACMM_RESET_UNKNOWN */
}

/* ---- watchdog: CMSDK APB watchdog at 0x40008000 on WDOGCLK = 25 MHz ----
 * The counter loads LOAD and counts down; at zero it raises its interrupt
 * (wired to the NMI on this board) and reloads; at zero again with the
 * interrupt still set it resets the system. A write to INTCLR clears the
 * interrupt and reloads the counter: the feed. The NMI is the early warning
 * (board_watchdog_warning), one timeout before the reset. */
#define WDOG_BASE 0x40008000u
#define WDOG_LOAD AACMM_REG32(WDOG_BASE + 0x000u)
#define WDOG_CTRL AACMM_REG32(WDOG_BASE + 0x008u)
#define WDOG_INTCLR AACMM_REG32(WDOG_BASE + 0x00Cu)
#define WDOG_LOCK AACMM_REG32(WDOG_BASE + 0xC00u)
#define WDOG_UNLOCK_KEY 0x1ACCE551u
#define WDOG_CTRL_INTEN 0x1u
#define WDOG_CTRL_RESEN 0x2u

void board_watchdog_warning(void) __attribute__((weak));
void board_watchdog_warning(void)
{
}

void NMI_Handler(void)
{
    board_watchdog_warning(); /* the interrupt stays set: the next timeout resets */
}

uint32_t board_watchdog_start(uint32_t timeout_ms)
{
    /* Half the timeout to the warning, half to the reset. */
    uint32_t half_ms = timeout_ms / 2u;
    if (half_ms == 0u || half_ms > 0xFFFFFFFFu / (CPU_HZ / 1000u)) {
        return 0u;
    }
    WDOG_LOCK = WDOG_UNLOCK_KEY;
    WDOG_LOAD = half_ms * (CPU_HZ / 1000u);
    WDOG_CTRL = WDOG_CTRL_INTEN | WDOG_CTRL_RESEN;
    WDOG_LOCK = 0u; /* lock the registers again */
    return half_ms * 2u;
}

void board_watchdog_feed(void)
{
    WDOG_LOCK = WDOG_UNLOCK_KEY;
    WDOG_INTCLR = 1u;
    WDOG_LOCK = 0u;
}

/* ---- parameter storage: RAM kept across resets ----
 * The MPS2's "flash" is SSRAM loaded from the SD card at power-up; QEMU has
 * no flash controller for it. The two record slots live in .noinit RAM,
 * which start-up does not clear: they survive a reset (measured under QEMU:
 * system reset request and watchdog reset), not a power cycle. */
const uint8_t board_storage_kind = 2u;  /* AACMM_STORAGE_KIND_RAM_RETAINED */
const uint8_t board_storage_flags = 0u; /* not persistent */
const uint8_t board_storage_has_erase = 0u;
#define STORE_BYTES 1024u
#define STORE_GUARD 0x53544F52u /* "STOR" */
__attribute__((section(".noinit"))) static uint8_t store[STORE_BYTES];
__attribute__((section(".noinit"))) static uint32_t store_guard;

static void store_init(void)
{
    if (store_guard != STORE_GUARD) { /* power-up: RAM holds anything */
        uint32_t i;
        for (i = 0; i < STORE_BYTES; i++) {
            store[i] = 0xFFu;
        }
        store_guard = STORE_GUARD;
    }
}

int board_storage_read(uint32_t offset, uint8_t *buf, size_t len)
{
    size_t i;
    if (offset > STORE_BYTES || len > STORE_BYTES - offset) {
        return -1;
    }
    store_init();
    for (i = 0; i < len; i++) {
        buf[i] = store[offset + i];
    }
    return 0;
}

int board_storage_write(uint32_t offset, const uint8_t *data, size_t len)
{
    size_t i;
    if (offset > STORE_BYTES || len > STORE_BYTES - offset) {
        return -1;
    }
    store_init();
    for (i = 0; i < len; i++) {
        store[offset + i] = data[i];
    }
    return 0;
}

int board_storage_erase(uint32_t offset, size_t len)
{
    (void)offset;
    (void)len;
    return -1; /* RAM needs no erase (board_storage_has_erase is 0) */
}

void board_init(void)
{
    systick_init();
    uart_init();
}
