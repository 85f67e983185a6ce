/*
 * Single-producer single-consumer byte ring for the UART drivers: one side
 * runs in the interrupt handler, the other in the main loop. The size is a
 * power of two; head and tail are free-running uint32 indices, each written
 * by one side only, so no lock is needed on a single core (word accesses
 * are atomic on Cortex-M).
 */
#ifndef AACMM_BOARD_RING_H
#define AACMM_BOARD_RING_H

#include <stddef.h>
#include <stdint.h>

typedef struct {
    volatile uint32_t head; /* written by the producer */
    volatile uint32_t tail; /* written by the consumer */
    uint8_t *buf;
    uint32_t mask; /* size - 1 */
} ring_t;

static inline uint32_t ring_used(const ring_t *r)
{
    return r->head - r->tail;
}

static inline uint32_t ring_free(const ring_t *r)
{
    return r->mask + 1u - ring_used(r);
}

static inline int ring_put(ring_t *r, uint8_t b)
{
    if (ring_free(r) == 0u) {
        return 0;
    }
    r->buf[r->head & r->mask] = b;
    r->head = r->head + 1u;
    return 1;
}

static inline int ring_get(ring_t *r, uint8_t *b)
{
    if (ring_used(r) == 0u) {
        return 0;
    }
    *b = r->buf[r->tail & r->mask];
    r->tail = r->tail + 1u;
    return 1;
}

#endif /* AACMM_BOARD_RING_H */
