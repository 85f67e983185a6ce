/*
 * ARM MPS2 with the AN386 FPGA image (Cortex-M4 with FPU, 25 MHz), as
 * emulated by QEMU's mps2-an386 machine.
 *
 * UART: CMSDK APB UART0 at 0x40004000, RX interrupt IRQ 0, TX interrupt IRQ 1,
 * interrupt driven: the rings and their rules are common/uart.c's. The CMSDK
 * UART holds one received byte (STATE.RXFULL); the RX interrupt hands it over
 * at once.
 * Time: SysTick on the 25 MHz processor clock, reload 2^24 - 1, extended to
 * 64 bits by counting wraps in SysTick_Handler.
 */
#include <stddef.h>
#include <stdint.h>

#include "board.h"
#include "board_startup.h"
#include "cortexm.h"
#include "uart.h"
#include "uart_hw.h"

const char board_name[] = "mps2-an386";

#define CPU_HZ 25000000u
const uint32_t board_tick_hz = CPU_HZ;

/* ---- CMSDK APB UART0 (registers: uart_hw.h) ---- */

/* RX: a byte received (an overrun is counted, then cleared). */
void IRQ0_Handler(void)
{
    UART_INTSTATUS = UART_INT_RX;
    if (UART_STATE & UART_STATE_RXOVERRUN) {
        UART_STATE = UART_STATE_RXOVERRUN; /* write 1 to clear */
        board_uart_isr_rx_error();
    }
    board_uart_isr_rx();
}

/* TX: the previous byte has gone. */
void IRQ1_Handler(void)
{
    UART_INTSTATUS = UART_INT_TX;
    board_uart_isr_tx_done();
}

static void uart_init(void)
{
    UART_CTRL = 0u;
    UART_BAUDDIV = CPU_HZ / UART_BAUD;
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

/* The store's bytes at offset, ready for use, or NULL if out of range. */
static uint8_t *store_at(uint32_t offset, size_t len)
{
    if (offset > STORE_BYTES || len > STORE_BYTES - offset) {
        return NULL;
    }
    store_init();
    return &store[offset];
}

int board_storage_read(uint32_t offset, uint8_t *buf, size_t len)
{
    const uint8_t *p = store_at(offset, len);
    size_t i;
    if (p == NULL) {
        return -1;
    }
    for (i = 0; i < len; i++) {
        buf[i] = p[i];
    }
    return 0;
}

int board_storage_write(uint32_t offset, const uint8_t *data, size_t len)
{
    uint8_t *p = store_at(offset, len);
    size_t i;
    if (p == NULL) {
        return -1;
    }
    for (i = 0; i < len; i++) {
        p[i] = data[i];
    }
    return 0;
}

int board_storage_erase(uint32_t offset, size_t len)
{
    (void)offset;
    (void)len;
    return -1; /* RAM needs no erase (board_storage_has_erase is 0) */
}

/* ---- temperature sensor: the MPS2 has none (the device gets no
 * read_temperatures) ---- */

int board_temp_probe(void)
{
    return 0;
}

int board_temp_read(int16_t *centi)
{
    (void)centi;
    return -1;
}

void board_init(void)
{
    systick_init();
    uart_init();
}
