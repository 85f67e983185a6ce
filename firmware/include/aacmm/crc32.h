/*
 * CRC-32/ISO-HDLC (the "CRC-32" of Ethernet, zlib and PNG), used by the link
 * protocol for serial frames and for the parameter-set checksum.
 *
 *   width 32, poly 0x04C11DB7 (reflected 0xEDB88320), init 0xFFFFFFFF,
 *   refin true, refout true, xorout 0xFFFFFFFF,
 *   check ("123456789") = 0xCBF43926, residue 0xDEBB20E3.
 *
 * Table-driven with a 16-entry (64-byte) nibble table: two lookups per byte.
 * No state, no heap; reentrant.
 */
#ifndef AACMM_CRC32_H
#define AACMM_CRC32_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define AACMM_CRC32_INIT 0xFFFFFFFFu  /* start value for aacmm_crc32_update */
#define AACMM_CRC32_CHECK 0xCBF43926u /* CRC of the ASCII bytes "123456789" */

/*
 * Continue a CRC over len bytes. Start with crc = AACMM_CRC32_INIT and finish
 * with aacmm_crc32_final. data may be NULL only if len is 0.
 * Returns the running (not yet finalised) CRC. Cost: O(len).
 */
uint32_t aacmm_crc32_update(uint32_t crc, const uint8_t *data, size_t len);

/* The final CRC value from a running one (xorout). Cost: O(1). */
uint32_t aacmm_crc32_final(uint32_t crc);

/* CRC-32/ISO-HDLC of len bytes in one call (NULL allowed if len is 0). O(len). */
uint32_t aacmm_crc32(const uint8_t *data, size_t len);

#ifdef __cplusplus
}
#endif

#endif /* AACMM_CRC32_H */
