/*
 * MPS2 AN386 CMSDK APB UART0: its registers, and the register access the
 * shared UART driver (common/uart.c, contract in common/uart.h) is built
 * with. Included by board.c and, on this board's build, by common/uart.c.
 */
#ifndef AACMM_BOARD_UART_HW_H
#define AACMM_BOARD_UART_HW_H

#include <stdint.h>

#include "cortexm.h"

#define UART0_BASE 0x40004000u
#define UART_DATA AACMM_REG32(UART0_BASE + 0x00u)
#define UART_STATE AACMM_REG32(UART0_BASE + 0x04u)
#define UART_CTRL AACMM_REG32(UART0_BASE + 0x08u)
#define UART_INTSTATUS AACMM_REG32(UART0_BASE + 0x0Cu) /* write 1 to clear */
#define UART_BAUDDIV AACMM_REG32(UART0_BASE + 0x10u)
#define UART_STATE_TXFULL 0x1u
#define UART_STATE_RXFULL 0x2u
#define UART_STATE_RXOVERRUN 0x8u
#define UART_CTRL_TXEN 0x1u
#define UART_CTRL_RXEN 0x2u
#define UART_CTRL_TXINTEN 0x4u
#define UART_CTRL_RXINTEN 0x8u
#define UART_INT_TX 0x1u
#define UART_INT_RX 0x2u
#define UART0_RX_IRQ 0u
#define UART0_TX_IRQ 1u
#define UART_BAUD 115200u


static inline void uart_hw_send(uint8_t b)
{
    UART_DATA = b;
}

/* The UART holds one received byte (STATE.RXFULL). */
static inline int uart_hw_rx_ready(void)
{
    return (UART_STATE & UART_STATE_RXFULL) != 0u;
}

static inline uint8_t uart_hw_rx_take(void)
{
    return (uint8_t)UART_DATA;
}

/* Off: the received byte stays in the UART. */
static inline void uart_hw_rx_pause(void)
{
    UART_CTRL = UART_CTRL & ~UART_CTRL_RXINTEN;
}

/* On again; the byte held in the UART raised its interrupt while it was
 * off, so pend the handler to take it. */
static inline void uart_hw_rx_resume(void)
{
    UART_CTRL = UART_CTRL | UART_CTRL_RXINTEN;
    cortexm_irq_pend(UART0_RX_IRQ);
}

#endif /* AACMM_BOARD_UART_HW_H */
