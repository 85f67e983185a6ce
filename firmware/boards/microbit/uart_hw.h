/*
 * micro:bit (nRF51) UART0: its registers, and the register access the shared
 * UART driver (common/uart.c, contract in common/uart.h) is built with.
 * Included by board.c and, on this board's build, by common/uart.c.
 */
#ifndef AACMM_BOARD_UART_HW_H
#define AACMM_BOARD_UART_HW_H

#include <stdint.h>

#include "cortexm.h"

#define UART0_BASE 0x40002000u
#define UART_TASKS_STARTRX AACMM_REG32(UART0_BASE + 0x000u)
#define UART_TASKS_STARTTX AACMM_REG32(UART0_BASE + 0x008u)
#define UART_EVENTS_RXDRDY AACMM_REG32(UART0_BASE + 0x108u)
#define UART_EVENTS_TXDRDY AACMM_REG32(UART0_BASE + 0x11Cu)
#define UART_EVENTS_ERROR AACMM_REG32(UART0_BASE + 0x124u)
#define UART_INTENSET AACMM_REG32(UART0_BASE + 0x304u)
#define UART_INTENCLR AACMM_REG32(UART0_BASE + 0x308u)
#define UART_ERRORSRC AACMM_REG32(UART0_BASE + 0x480u)
#define UART_ENABLE AACMM_REG32(UART0_BASE + 0x500u)
#define UART_PSELRTS AACMM_REG32(UART0_BASE + 0x508u)
#define UART_PSELTXD AACMM_REG32(UART0_BASE + 0x50Cu)
#define UART_PSELCTS AACMM_REG32(UART0_BASE + 0x510u)
#define UART_PSELRXD AACMM_REG32(UART0_BASE + 0x514u)
#define UART_RXD AACMM_REG32(UART0_BASE + 0x518u)
#define UART_TXD AACMM_REG32(UART0_BASE + 0x51Cu)
#define UART_BAUDRATE AACMM_REG32(UART0_BASE + 0x524u)
#define UART_CONFIG AACMM_REG32(UART0_BASE + 0x56Cu)
#define UART_INT_RXDRDY (1u << 2)
#define UART_INT_TXDRDY (1u << 7)
#define UART_INT_ERROR (1u << 9)
#define UART_ENABLE_ON 4u
#define UART_BAUD_115200 0x01D7E000u
#define UART_PIN_DISCONNECTED 0xFFFFFFFFu
#define MICROBIT_TX_PIN 24u
#define MICROBIT_RX_PIN 25u
#define UART0_IRQ 2u


static inline void uart_hw_send(uint8_t b)
{
    UART_TXD = b;
}

static inline int uart_hw_rx_ready(void)
{
    return UART_EVENTS_RXDRDY != 0u;
}

/* Acknowledge RXDRDY, then take the byte (the next one raises it again). */
static inline uint8_t uart_hw_rx_take(void)
{
    UART_EVENTS_RXDRDY = 0u;
    return (uint8_t)UART_RXD;
}

/* Off: received bytes stay in the UART's FIFO. */
static inline void uart_hw_rx_pause(void)
{
    UART_INTENCLR = UART_INT_RXDRDY;
}

/* On again: a pending RXDRDY event fires the handler. */
static inline void uart_hw_rx_resume(void)
{
    UART_INTENSET = UART_INT_RXDRDY;
}

#endif /* AACMM_BOARD_UART_HW_H */
