/*
 * The bare-metal harness of the Cortex-M benches that run under QEMU
 * (bench_fixed_m0.c, bench_em_cm.c): vector table, .data/.bss set-up (and
 * the FPU's enable where the core has one), semihosting output and exit, and
 * SysTick's registers. Included once, by the bench's only C file: the
 * linker scripts (bench/m0_microbit.ld, bench/m4f_mps2.ld) give the
 * symbols; the bench defines main().
 */
#ifndef AACMM_BENCH_BARE_METAL_H
#define AACMM_BENCH_BARE_METAL_H

#include <stdint.h>

extern uint32_t __stack_top, __data_start, __data_end, __data_load, __bss_start, __bss_end;
int main(void);
void reset_handler(void);

static uint32_t semihost(uint32_t op, const void *arg)
{
    register uint32_t r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

__attribute__((section(".vectors"), used)) static const void *const vectors[16] = {
    &__stack_top, (const void *)(uintptr_t)reset_handler};

void reset_handler(void)
{
    const uint32_t *s = &__data_load;
    uint32_t *d = &__data_start;
#if defined(__ARM_FP)
    *(volatile uint32_t *)0xE000ED88u |= 0xFu << 20; /* CPACR: CP10, CP11 full access */
    __asm__ volatile("dsb\n\tisb" ::: "memory");
#endif
    while (d < &__data_end) {
        *d++ = *s++;
    }
    for (d = &__bss_start; d < &__bss_end;) {
        *d++ = 0u;
    }
    (void)main();
    (void)semihost(0x18u, (const void *)(uintptr_t)0x20026u); /* SYS_EXIT, application exit */
    for (;;) {
    }
}

/* One NUL-terminated string to the host's stdout. */
static void put(const char *s)
{
    (void)semihost(0x04u, s); /* SYS_WRITE0 */
}

/* v in decimal. */
static void put_u32(uint32_t v)
{
    char b[12];
    int i = 11;
    b[i] = '\0';
    do {
        b[--i] = (char)('0' + (int)(v % 10u));
        v /= 10u;
    } while (v != 0u);
    put(b + i);
}

#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)

#endif
