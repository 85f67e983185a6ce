/*
 * Single-producer single-consumer byte ring for the UART driver (uart.c):
 * one side runs in the interrupt handler, the other in the main loop.
 *
 * The caller owns the storage: a ring_t (the two indices) and a buffer of
 * `size` bytes, size a power of two (2 .. 2^31) passed at every call; with
 * a compile-time constant size the mask folds into the code and the ring
 * needs no initialised data. head and tail are free-running uint32 counts
 * (bytes put, bytes taken), each written by one side only, so no lock is
 * needed on a single core (aligned word accesses are atomic on Cortex-M);
 * used = head - tail is right across their wrap. Zero-initialised: empty.
 * Every function is O(1).
 */
#ifndef AACMM_BOARD_RING_H
#define AACMM_BOARD_RING_H

#include <stdint.h>

typedef struct {
    volatile uint32_t head; /* bytes put: written by the producer only */
    volatile uint32_t tail; /* bytes taken: written by the consumer only */
} ring_t;

/* Bytes waiting (0 .. size). Either side may ask. */
static inline uint32_t ring_used(const ring_t *r)
{
    return r->head - r->tail;
}

/* Producer: store b; 1 if stored, 0 if the ring is full. */
static inline int ring_put(ring_t *r, uint8_t *buf, uint32_t size, uint8_t b)
{
    if (ring_used(r) >= size) {
        return 0;
    }
    buf[r->head & (size - 1u)] = b;
    r->head = r->head + 1u;
    return 1;
}

/* Consumer: take the oldest byte into *b; 1 if taken, 0 if the ring is empty. */
static inline int ring_get(ring_t *r, const uint8_t *buf, uint32_t size, uint8_t *b)
{
    if (ring_used(r) == 0u) {
        return 0;
    }
    *b = buf[r->tail & (size - 1u)];
    r->tail = r->tail + 1u;
    return 1;
}

#endif /* AACMM_BOARD_RING_H */
