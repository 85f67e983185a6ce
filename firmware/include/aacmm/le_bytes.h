/*
 * Little-endian byte access: every aacmm byte format is little-endian (the
 * link protocol's fields and frame CRC, docs/protocol.md; the CAN sample
 * frames; the stored parameter record, aacmm/device.h; the device's output
 * queue), and these are the one copy of the packing they share. p points to
 * at least 2 or 4 bytes, any alignment. Static inline, no state; O(1).
 */
#ifndef AACMM_LE_BYTES_H
#define AACMM_LE_BYTES_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

static inline void aacmm_le_put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)(v & 0xFFu);
    p[1] = (uint8_t)(v >> 8);
}

static inline void aacmm_le_put_u32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v & 0xFFu);
    p[1] = (uint8_t)((v >> 8) & 0xFFu);
    p[2] = (uint8_t)((v >> 16) & 0xFFu);
    p[3] = (uint8_t)(v >> 24);
}

static inline uint16_t aacmm_le_get_u16(const uint8_t *p)
{
    return (uint16_t)((uint16_t)p[0] | (uint16_t)((uint16_t)p[1] << 8));
}

static inline uint32_t aacmm_le_get_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) |
           ((uint32_t)p[3] << 24);
}

#ifdef __cplusplus
}
#endif

#endif /* AACMM_LE_BYTES_H */
