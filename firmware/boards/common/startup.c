/*
 * Reset handler and vector table for the Cortex-M board ports (our own; no
 * vendor startup file). The linker script (sections.ld) provides the symbols
 * below and places .vectors at the start of the boot memory.
 *
 * Reset: copy .data from its load address in flash, zero .bss, turn on the
 * FPU when the build uses one (CP10/CP11 full access), then main(). main
 * never returns in the device images; if it does, the core sleeps.
 *
 * Interrupts: the table has the 16 system entries plus 32 external
 * interrupts (both ports' NVICs have 32 lines). Every handler is a weak alias
 * of default_handler, so a port overrides exactly the ones it uses by
 * defining IRQn_Handler / SysTick_Handler.
 */
#include <stdint.h>

#include "board.h"
#include "board_startup.h"
#include "cortexm.h"

extern uint32_t __stack_top;
extern uint32_t __data_load;
extern uint32_t __data_start;
extern uint32_t __data_end;
extern uint32_t __bss_start;
extern uint32_t __bss_end;

int main(void);

/* The weak defaults of the hooks board.h and board_startup.h declare, for
 * every board (device_main.c overrides what the device image needs). */
void board_fault_hook(uint32_t ipsr) __attribute__((weak));
void board_fault_hook(uint32_t ipsr)
{
    (void)ipsr;
    for (;;) {
    }
}

void board_watchdog_warning(void) __attribute__((weak));
void board_watchdog_warning(void)
{
}

int board_flash_hook(uint32_t step, uint32_t *word) __attribute__((weak));
int board_flash_hook(uint32_t step, uint32_t *word)
{
    (void)step;
    (void)word;
    return 0;
}

void default_handler(void)
{
    uint32_t ipsr;
    __asm__ volatile("mrs %0, ipsr" : "=r"(ipsr));
    board_fault_hook(ipsr & 0x1FFu);
}

/* SYSRESETREQ: the whole chip resets (board.h). */
void board_system_reset(void)
{
    __asm__ volatile("dsb" ::: "memory");
    SCB_AIRCR = SCB_AIRCR_SYSRESETREQ;
    __asm__ volatile("dsb" ::: "memory");
    for (;;) {
    }
}

void Reset_Handler(void)
{
    uint32_t *src = &__data_load;
    uint32_t *dst = &__data_start;
    while (dst < &__data_end) {
        *dst++ = *src++;
    }
    for (dst = &__bss_start; dst < &__bss_end; dst++) {
        *dst = 0u;
    }
#if defined(__ARM_FP)
    SCB_CPACR |= 0xFu << 20; /* CP10, CP11: full access */
    __asm__ volatile("dsb\n\tisb" ::: "memory");
#endif
    (void)main();
    for (;;) {
        cortexm_wfi();
    }
}

#define WEAK_ALIAS __attribute__((weak, alias("default_handler")))
void NMI_Handler(void) WEAK_ALIAS;
void HardFault_Handler(void) WEAK_ALIAS;
void MemManage_Handler(void) WEAK_ALIAS;
void BusFault_Handler(void) WEAK_ALIAS;
void UsageFault_Handler(void) WEAK_ALIAS;
void SVC_Handler(void) WEAK_ALIAS;
void DebugMon_Handler(void) WEAK_ALIAS;
void PendSV_Handler(void) WEAK_ALIAS;
void SysTick_Handler(void) WEAK_ALIAS;
void IRQ0_Handler(void) WEAK_ALIAS;
void IRQ1_Handler(void) WEAK_ALIAS;
void IRQ2_Handler(void) WEAK_ALIAS;
void IRQ3_Handler(void) WEAK_ALIAS;
void IRQ4_Handler(void) WEAK_ALIAS;
void IRQ5_Handler(void) WEAK_ALIAS;
void IRQ6_Handler(void) WEAK_ALIAS;
void IRQ7_Handler(void) WEAK_ALIAS;
void IRQ8_Handler(void) WEAK_ALIAS;
void IRQ9_Handler(void) WEAK_ALIAS;
void IRQ10_Handler(void) WEAK_ALIAS;
void IRQ11_Handler(void) WEAK_ALIAS;
void IRQ12_Handler(void) WEAK_ALIAS;
void IRQ13_Handler(void) WEAK_ALIAS;
void IRQ14_Handler(void) WEAK_ALIAS;
void IRQ15_Handler(void) WEAK_ALIAS;
void IRQ16_Handler(void) WEAK_ALIAS;
void IRQ17_Handler(void) WEAK_ALIAS;
void IRQ18_Handler(void) WEAK_ALIAS;
void IRQ19_Handler(void) WEAK_ALIAS;
void IRQ20_Handler(void) WEAK_ALIAS;
void IRQ21_Handler(void) WEAK_ALIAS;
void IRQ22_Handler(void) WEAK_ALIAS;
void IRQ23_Handler(void) WEAK_ALIAS;
void IRQ24_Handler(void) WEAK_ALIAS;
void IRQ25_Handler(void) WEAK_ALIAS;
void IRQ26_Handler(void) WEAK_ALIAS;
void IRQ27_Handler(void) WEAK_ALIAS;
void IRQ28_Handler(void) WEAK_ALIAS;
void IRQ29_Handler(void) WEAK_ALIAS;
void IRQ30_Handler(void) WEAK_ALIAS;
void IRQ31_Handler(void) WEAK_ALIAS;

typedef void (*handler_t)(void);

/* The first word is the initial stack pointer: a struct keeps it a data
 * pointer (ISO C has no object-to-function pointer conversion). */
struct vector_table {
    uint32_t *initial_sp;
    handler_t vectors[15 + 32];
};

__attribute__((section(".vectors"), used)) const struct vector_table aacmm_vector_table = {
    &__stack_top,
    {
        Reset_Handler,      NMI_Handler,    HardFault_Handler, MemManage_Handler,
        BusFault_Handler,   UsageFault_Handler,
        0, 0, 0, 0, /* reserved */
        SVC_Handler,        DebugMon_Handler,
        0, /* reserved */
        PendSV_Handler,     SysTick_Handler,
        IRQ0_Handler,  IRQ1_Handler,  IRQ2_Handler,  IRQ3_Handler,  IRQ4_Handler,  IRQ5_Handler,
        IRQ6_Handler,  IRQ7_Handler,  IRQ8_Handler,  IRQ9_Handler,  IRQ10_Handler, IRQ11_Handler,
        IRQ12_Handler, IRQ13_Handler, IRQ14_Handler, IRQ15_Handler, IRQ16_Handler, IRQ17_Handler,
        IRQ18_Handler, IRQ19_Handler, IRQ20_Handler, IRQ21_Handler, IRQ22_Handler, IRQ23_Handler,
        IRQ24_Handler, IRQ25_Handler, IRQ26_Handler, IRQ27_Handler, IRQ28_Handler, IRQ29_Handler,
        IRQ30_Handler, IRQ31_Handler,
    },
};
