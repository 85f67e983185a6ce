/*
 * Minimal Cortex-M core register definitions shared by the board ports
 * (ARMv6-M and ARMv7-M system control space). Only what the ports use.
 */
#ifndef AACMM_BOARD_CORTEXM_H
#define AACMM_BOARD_CORTEXM_H

#include <stdint.h>

#define AACMM_REG32(addr) (*(volatile uint32_t *)(uintptr_t)(addr))

/* SysTick (24-bit down counter). */
#define SYST_CSR AACMM_REG32(0xE000E010u)
#define SYST_RVR AACMM_REG32(0xE000E014u)
#define SYST_CVR AACMM_REG32(0xE000E018u)
#define SYST_CALIB AACMM_REG32(0xE000E01Cu)
#define SYST_CSR_ENABLE 0x1u
#define SYST_CSR_TICKINT 0x2u
#define SYST_CSR_CLKSOURCE 0x4u /* 1 = processor clock */
#define SYST_CSR_COUNTFLAG 0x10000u
#define SYST_MAX_RELOAD 0x00FFFFFFu

/* NVIC. */
#define NVIC_ISER0 AACMM_REG32(0xE000E100u)
#define NVIC_ICER0 AACMM_REG32(0xE000E180u)
#define NVIC_ISPR0 AACMM_REG32(0xE000E200u)
#define NVIC_ICPR0 AACMM_REG32(0xE000E280u)

/* System control block. */
#define SCB_ICSR AACMM_REG32(0xE000ED04u)
#define SCB_VTOR AACMM_REG32(0xE000ED08u)
#define SCB_AIRCR AACMM_REG32(0xE000ED0Cu)
#define SCB_CPACR AACMM_REG32(0xE000ED88u) /* ARMv7-M only */
#define SCB_AIRCR_SYSRESETREQ (0x05FA0000u | 0x4u)

static inline void cortexm_irq_enable(unsigned irq)
{
    NVIC_ISER0 = 1u << irq;
}

static inline void cortexm_irq_pend(unsigned irq)
{
    NVIC_ISPR0 = 1u << irq;
}

static inline void cortexm_irq_disable(unsigned irq)
{
    NVIC_ICER0 = 1u << irq;
}

/* PRIMASK save/restore for short critical sections. */
static inline uint32_t cortexm_irq_save(void)
{
    uint32_t primask;
    __asm__ volatile("mrs %0, primask\n\tcpsid i" : "=r"(primask)::"memory");
    return primask;
}

static inline void cortexm_irq_restore(uint32_t primask)
{
    __asm__ volatile("msr primask, %0" ::"r"(primask) : "memory");
}

static inline void cortexm_wfi(void)
{
    __asm__ volatile("wfi" ::: "memory");
}

#endif /* AACMM_BOARD_CORTEXM_H */
