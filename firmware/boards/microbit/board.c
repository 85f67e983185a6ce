/*
 * BBC micro:bit v1 (Nordic nRF51822: Cortex-M0 at 16 MHz, no FPU, 256 KiB
 * flash, 16 KiB RAM), as on the board and as emulated by QEMU's microbit
 * machine.
 *
 * UART: nRF51 UART0 at 0x40002000 (IRQ 2), TX on P0.24 and RX on P0.25 (the
 * interface chip's USB-serial bridge), 115200 8N1, interrupt driven: the
 * rings and their rules are common/uart.c's; here RXDRDY hands each received
 * byte to it and TXDRDY asks it for the next byte to send.
 *
 * Time: the nRF51 has no SysTick (the Cortex-M0 is built without it), so
 * the time base is TIMER0 in 32-bit mode at 16 MHz (prescaler 0): CAPTURE[0]
 * latches the counter into CC[0]. board_ticks extends it to 64 bits by
 * accumulating the difference since the previous call, which is exact as
 * long as it is called at least once per 2^32 ticks (268 s); the device
 * loop calls it on every pass. QEMU's microbit machine models the same timer
 * on its virtual clock, so with -icount shift=0 one tick is 62.5 instructions
 * (measured by the self-test: see docs/boards.md).
 *
 * Temperature: the nRF51's TEMP peripheral (0x4000C000, the die's
 * temperature in 0.25 degC steps, one conversion in about 36 us), read
 * without blocking: each board_temp_read takes the conversion that
 * completed since the previous call and starts the next one. Probed once at
 * start-up with a bounded wait. QEMU's microbit machine does not model TEMP
 * (its registers read 0 in the SoC's unimplemented I/O region), so there
 * the probe fails and the device has no link temperatures (docs/boards.md).
 */
#include <stddef.h>
#include <stdint.h>

#include "board.h"
#include "board_startup.h"
#include "cortexm.h"
#include "uart.h"
#include "uart_hw.h"

const char board_name[] = "microbit";

#define TIMER_HZ 16000000u
const uint32_t board_tick_hz = TIMER_HZ;

/* GPIO: the TX pin must be an output driven high while idle. */
#define GPIO_OUTSET AACMM_REG32(0x50000508u)
#define GPIO_PIN_CNF(n) AACMM_REG32(0x50000700u + 4u * (n))

/* ---- UART0 (registers: uart_hw.h) ---- */

/* One handler for both directions: received bytes (RXDRDY), line errors
 * (counted, then cleared), the previous byte sent (TXDRDY). */
void IRQ2_Handler(void)
{
    board_uart_isr_rx();
    if (UART_EVENTS_ERROR) {
        UART_EVENTS_ERROR = 0u;
        UART_ERRORSRC = UART_ERRORSRC; /* write 1s to clear */
        board_uart_isr_rx_error();
    }
    if (UART_EVENTS_TXDRDY) {
        UART_EVENTS_TXDRDY = 0u;
        board_uart_isr_tx_done();
    }
}

static void uart_init(void)
{
    GPIO_OUTSET = 1u << MICROBIT_TX_PIN;
    GPIO_PIN_CNF(MICROBIT_TX_PIN) = 1u; /* output, input buffer disconnected */
    GPIO_PIN_CNF(MICROBIT_RX_PIN) = 0u; /* input */
    UART_PSELTXD = MICROBIT_TX_PIN;
    UART_PSELRXD = MICROBIT_RX_PIN;
    UART_PSELRTS = UART_PIN_DISCONNECTED;
    UART_PSELCTS = UART_PIN_DISCONNECTED;
    UART_CONFIG = 0u; /* no parity, no flow control */
    UART_BAUDRATE = UART_BAUD_115200;
    UART_ENABLE = UART_ENABLE_ON;
    UART_EVENTS_RXDRDY = 0u;
    UART_EVENTS_TXDRDY = 0u;
    UART_EVENTS_ERROR = 0u;
    UART_TASKS_STARTTX = 1u;
    UART_TASKS_STARTRX = 1u;
    UART_INTENSET = UART_INT_RXDRDY | UART_INT_TXDRDY | UART_INT_ERROR;
    cortexm_irq_enable(UART0_IRQ);
}

/* ---- TEMP: die temperature sensor ---- */
#define TEMP_BASE 0x4000C000u
#define TEMP_TASKS_START AACMM_REG32(TEMP_BASE + 0x000u)
#define TEMP_TASKS_STOP AACMM_REG32(TEMP_BASE + 0x004u)
#define TEMP_EVENTS_DATARDY AACMM_REG32(TEMP_BASE + 0x100u)
#define TEMP_INTENCLR AACMM_REG32(TEMP_BASE + 0x308u)
#define TEMP_TRIM AACMM_REG32(TEMP_BASE + 0x504u) /* nRF51 anomaly: load 0 before use */
#define TEMP_TEMP AACMM_REG32(TEMP_BASE + 0x508u)
#define TEMP_RESTART_US 1000u /* a conversion not done by then is started again */

static uint8_t temp_present;  /* the probe saw a conversion */
static uint8_t temp_running;  /* a conversion was started and not yet taken */
static uint8_t temp_have;     /* temp_centi holds a reading */
static int16_t temp_centi;    /* the latest reading, 0.01 degC */
static uint64_t temp_done_us; /* when it was taken */
static uint64_t temp_start_us;

/* TEMP in 0.25 degC steps as 0.01 degC: the register's 10-bit two's
 * complement value (the nRF51 leaves the upper bits of a negative one
 * clear), sign-extended. */
static int16_t temp_convert(uint32_t reg)
{
    int32_t q = (int32_t)(reg & 0x3FFu);
    if ((q & 0x200) != 0) {
        q -= 0x400;
    }
    return (int16_t)(q * 25);
}

static void temp_start(uint64_t now)
{
    TEMP_EVENTS_DATARDY = 0u;
    TEMP_TASKS_START = 1u;
    temp_running = 1u;
    temp_start_us = now;
}

/* Take a completed conversion (and start the next); restart one that did
 * not complete. Never waits. */
static void temp_service(uint64_t now)
{
    if (temp_running && TEMP_EVENTS_DATARDY != 0u) {
        temp_centi = temp_convert(TEMP_TEMP);
        temp_have = 1u;
        temp_done_us = now;
        temp_running = 0u;
        TEMP_TASKS_STOP = 1u; /* power the sensor down between conversions */
    }
    if (!temp_running || now - temp_start_us > TEMP_RESTART_US) {
        if (temp_running) {
            TEMP_TASKS_STOP = 1u;
        }
        temp_start(now);
    }
}

int board_temp_probe(void)
{
    uint64_t t0;
    TEMP_INTENCLR = 1u; /* polled, no interrupt */
    TEMP_TRIM = 0u;
    t0 = board_time_us();
    temp_start(t0);
    while (TEMP_EVENTS_DATARDY == 0u) {
        if (board_time_us() - t0 > BOARD_TEMP_PROBE_US) {
            TEMP_TASKS_STOP = 1u;
            temp_running = 0u;
            return 0; /* no conversion: no sensor (QEMU) */
        }
    }
    temp_present = 1u;
    temp_service(board_time_us());
    return 1;
}

int board_temp_read(int16_t *centi)
{
    uint64_t now;
    if (!temp_present) {
        return -1;
    }
    now = board_time_us();
    temp_service(now);
    if (!temp_have || now - temp_done_us > BOARD_TEMP_TIMEOUT_US) {
        return -1;
    }
    *centi = temp_centi;
    return 0;
}

/* ---- TIMER0 time base ---- */
#define TIMER0_BASE 0x40008000u
#define TIMER_TASKS_START AACMM_REG32(TIMER0_BASE + 0x000u)
#define TIMER_TASKS_STOP AACMM_REG32(TIMER0_BASE + 0x004u)
#define TIMER_TASKS_CLEAR AACMM_REG32(TIMER0_BASE + 0x00Cu)
#define TIMER_TASKS_CAPTURE0 AACMM_REG32(TIMER0_BASE + 0x040u)
#define TIMER_MODE AACMM_REG32(TIMER0_BASE + 0x504u)
#define TIMER_BITMODE AACMM_REG32(TIMER0_BASE + 0x508u)
#define TIMER_PRESCALER AACMM_REG32(TIMER0_BASE + 0x510u)
#define TIMER_CC0 AACMM_REG32(TIMER0_BASE + 0x540u)
#define TIMER_BITMODE_32 3u

static uint32_t timer_last;
static uint64_t timer_acc;

uint64_t board_ticks(void)
{
    uint32_t primask = cortexm_irq_save();
    uint32_t now;
    uint64_t t;
    TIMER_TASKS_CAPTURE0 = 1u;
    now = TIMER_CC0;
    timer_acc += (uint32_t)(now - timer_last);
    timer_last = now;
    t = timer_acc;
    cortexm_irq_restore(primask);
    return t;
}

uint64_t board_time_us(void)
{
    return board_ticks() / (TIMER_HZ / 1000000u);
}

static void timer_init(void)
{
    TIMER_TASKS_STOP = 1u;
    TIMER_MODE = 0u; /* timer */
    TIMER_BITMODE = TIMER_BITMODE_32;
    TIMER_PRESCALER = 0u; /* 16 MHz */
    TIMER_TASKS_CLEAR = 1u;
    TIMER_TASKS_START = 1u;
    timer_last = 0u;
    timer_acc = 0u;
}

/* ---- TIMER1: 1 kHz wake-up ---- */
#define TIMER1_BASE 0x40009000u
#define TIMER1_TASKS_START AACMM_REG32(TIMER1_BASE + 0x000u)
#define TIMER1_TASKS_STOP AACMM_REG32(TIMER1_BASE + 0x004u)
#define TIMER1_TASKS_CLEAR AACMM_REG32(TIMER1_BASE + 0x00Cu)
#define TIMER1_EVENTS_COMPARE0 AACMM_REG32(TIMER1_BASE + 0x140u)
#define TIMER1_SHORTS AACMM_REG32(TIMER1_BASE + 0x200u)
#define TIMER1_INTENSET AACMM_REG32(TIMER1_BASE + 0x304u)
#define TIMER1_MODE AACMM_REG32(TIMER1_BASE + 0x504u)
#define TIMER1_BITMODE AACMM_REG32(TIMER1_BASE + 0x508u)
#define TIMER1_PRESCALER AACMM_REG32(TIMER1_BASE + 0x510u)
#define TIMER1_CC0 AACMM_REG32(TIMER1_BASE + 0x540u)
#define TIMER1_IRQ 9u
#define TIMER_SHORTS_COMPARE0_CLEAR 1u
#define TIMER_INT_COMPARE0 (1u << 16)

void IRQ9_Handler(void)
{
    TIMER1_EVENTS_COMPARE0 = 0u;
}

static void wake_timer_init(void)
{
    TIMER1_TASKS_STOP = 1u;
    TIMER1_MODE = 0u;
    TIMER1_BITMODE = 0u;   /* 16 bit */
    TIMER1_PRESCALER = 4u; /* 1 MHz */
    TIMER1_CC0 = 1000u;    /* 1 ms */
    TIMER1_SHORTS = TIMER_SHORTS_COMPARE0_CLEAR;
    TIMER1_EVENTS_COMPARE0 = 0u;
    TIMER1_INTENSET = TIMER_INT_COMPARE0;
    TIMER1_TASKS_CLEAR = 1u;
    TIMER1_TASKS_START = 1u;
    cortexm_irq_enable(TIMER1_IRQ);
}

/* ---- reset cause: POWER.RESETREAS ----
 * Bits: RESETPIN 0, DOG 1, SREQ 2, LOCKUP 3 (and wake-ups from System OFF);
 * none after a power-on reset. The bits accumulate until written back.
 * QEMU's microbit does not model it: the register reads 1 whatever happened
 * (measured), so under QEMU a reset the device image did not record itself
 * shows as "reset pin". */
#define POWER_RESETREAS AACMM_REG32(0x40000400u)
#define RESETREAS_RESETPIN 0x1u
#define RESETREAS_DOG 0x2u
#define RESETREAS_SREQ 0x4u
#define RESETREAS_LOCKUP 0x8u

static uint32_t reset_register;

uint32_t board_reset_register(void)
{
    return reset_register;
}

uint8_t board_reset_cause(uint32_t reg)
{
    if (reg & RESETREAS_DOG) {
        return 3u; /* AACMM_RESET_WATCHDOG */
    }
    if (reg & RESETREAS_LOCKUP) {
        return 5u; /* AACMM_RESET_FAULT */
    }
    if (reg & RESETREAS_SREQ) {
        return 4u; /* AACMM_RESET_SOFTWARE */
    }
    if (reg & RESETREAS_RESETPIN) {
        return 2u; /* AACMM_RESET_PIN */
    }
    return 0u; /* AACMM_RESET_UNKNOWN (power-on is told by RAM, see device_main.c) */
}

/* ---- watchdog: nRF51 WDT on the 32.768 kHz clock ----
 * Starting it forces the low-frequency RC oscillator on. It runs while the
 * CPU sleeps and pauses while a debugger halts it; once started it cannot be
 * stopped or changed until a reset. Its TIMEOUT interrupt (IRQ 16) comes two
 * 32 kHz cycles before the reset: the early warning. QEMU's microbit does
 * not model the WDT (measured: its registers read 0 and it never resets);
 * the image starts and feeds it all the same, for real boards. */
#define WDT_BASE 0x40010000u
#define WDT_TASKS_START AACMM_REG32(WDT_BASE + 0x000u)
#define WDT_EVENTS_TIMEOUT AACMM_REG32(WDT_BASE + 0x100u)
#define WDT_INTENSET AACMM_REG32(WDT_BASE + 0x304u)
#define WDT_CRV AACMM_REG32(WDT_BASE + 0x504u)
#define WDT_RREN AACMM_REG32(WDT_BASE + 0x508u)
#define WDT_CONFIG AACMM_REG32(WDT_BASE + 0x50Cu)
#define WDT_RR0 AACMM_REG32(WDT_BASE + 0x600u)
#define WDT_RELOAD 0x6E524635u
#define WDT_CONFIG_SLEEP_RUN 0x1u
#define WDT_IRQ 16u

void IRQ16_Handler(void)
{
    WDT_EVENTS_TIMEOUT = 0u;
    board_watchdog_warning();
}

uint32_t board_watchdog_start(uint32_t timeout_ms)
{
    uint64_t crv = (uint64_t)timeout_ms * 32768u / 1000u;
    if (crv < 16u || crv > 0xFFFFFFFFu) {
        return 0u;
    }
    WDT_CRV = (uint32_t)(crv - 1u);
    WDT_RREN = 1u; /* reload register 0 only */
    WDT_CONFIG = WDT_CONFIG_SLEEP_RUN;
    WDT_INTENSET = 1u; /* TIMEOUT */
    cortexm_irq_enable(WDT_IRQ);
    WDT_TASKS_START = 1u;
    return timeout_ms;
}

void board_watchdog_feed(void)
{
    WDT_RR0 = WDT_RELOAD;
}

/* ---- parameter storage: two flash pages through the NVMC ----
 * The last two 1 KiB pages of the 256 KiB flash (memory.ld keeps the image
 * out of them): slot 0 at 0x3F800, slot 1 at 0x3FC00. A save erases the
 * target slot's page (NVMC ERASEPAGE), then programs the record a 32-bit
 * word at a time (CONFIG = WEN); programming can only clear bits. Reads are
 * plain memory reads. The CPU stalls during each operation (an erase takes
 * up to about 22 ms on the chip, a word about 46 us; the watchdog keeps
 * counting). The chip's flash is rated for 20,000 erase cycles per page and
 * saves alternate between the two pages: 40,000 saves, a lifetime of
 * calibrations (a save a minute, nonstop, would take four weeks). QEMU
 * models the NVMC (erase, word writes that only clear bits) and keeps the
 * flash across a system reset, not across QEMU runs. */
#define NVMC_READY AACMM_REG32(0x4001E400u)
#define NVMC_CONFIG AACMM_REG32(0x4001E504u)
#define NVMC_ERASEPAGE AACMM_REG32(0x4001E508u)
#define NVMC_REN 0u
#define NVMC_WEN 1u
#define NVMC_EEN 2u
#define STORE_SLOT_BYTES 512u
#define STORE_PAGE0 0x0003F800u
#define STORE_PAGE_BYTES 1024u

const uint8_t board_storage_kind = 4u;  /* AACMM_STORAGE_KIND_FLASH */
const uint8_t board_storage_flags = 1u; /* AACMM_STORAGE_PERSISTENT */
const uint8_t board_storage_has_erase = 1u;

static void nvmc_wait(void)
{
    while (NVMC_READY == 0u) {
    }
}

/* Enter an NVMC mode (read, write or erase enable) once it is idle. */
static void nvmc_mode(uint32_t mode)
{
    nvmc_wait();
    NVMC_CONFIG = mode;
    nvmc_wait();
}

/* Flash address of storage byte offset, or 0 if out of range. */
static uint32_t store_address(uint32_t offset, size_t len)
{
    uint32_t slot = offset / STORE_SLOT_BYTES;
    uint32_t inner = offset % STORE_SLOT_BYTES;
    if (slot > 1u || len > STORE_SLOT_BYTES - inner) {
        return 0u;
    }
    return STORE_PAGE0 + slot * STORE_PAGE_BYTES + inner;
}

int board_storage_read(uint32_t offset, uint8_t *buf, size_t len)
{
    uint32_t a = store_address(offset, len);
    size_t i;
    if (a == 0u) {
        return -1;
    }
    for (i = 0; i < len; i++) {
        buf[i] = *(const volatile uint8_t *)(uintptr_t)(a + i);
    }
    return 0;
}

int board_storage_erase(uint32_t offset, size_t len)
{
    uint32_t a = store_address(offset, len);
    int cut;
    if (a == 0u) {
        return -1;
    }
    cut = board_flash_hook(0u, NULL);
    nvmc_mode(NVMC_EEN);
    NVMC_ERASEPAGE = a & ~(STORE_PAGE_BYTES - 1u);
    nvmc_mode(NVMC_REN);
    if (cut) {
        board_system_reset();
    }
    return 0;
}

int board_storage_write(uint32_t offset, const uint8_t *data, size_t len)
{
    uint32_t a = store_address(offset, len);
    size_t i;
    if (a == 0u || (a & 3u) != 0u) {
        return -1;
    }
    for (i = 0; i < len; i += 4u) {
        uint32_t w = 0xFFFFFFFFu; /* a partial last word keeps erased bytes */
        size_t k;
        int cut;
        for (k = 0; k < 4u && i + k < len; k++) {
            w &= ~((uint32_t)0xFFu << (8u * k));
            w |= (uint32_t)data[i + k] << (8u * k);
        }
        cut = board_flash_hook(1u + (uint32_t)(i / 4u), &w);
        nvmc_mode(NVMC_WEN);
        *(volatile uint32_t *)(uintptr_t)(a + i) = w;
        nvmc_mode(NVMC_REN);
        if (cut) {
            board_system_reset();
        }
    }
    return 0;
}

void board_init(void)
{
    reset_register = POWER_RESETREAS;
    POWER_RESETREAS = reset_register; /* write 1s to clear */
    timer_init();
    wake_timer_init();
    uart_init();
}
