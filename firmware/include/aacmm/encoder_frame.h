/*
 * Absolute-encoder frames: turn what an encoder interface sampled on the data
 * line into a position, or into a fault. Never a wrong position: a frame is
 * accepted only when every check its protocol offers passes.
 *
 * A port's encoder interface (SPI peripheral, timer capture, PIO, bit-banged
 * GPIO) clocks the encoder and records the data line's level once per clock,
 * the first clock first. aacmm_enc_frame_t holds those levels; the decoder
 * knows the layouts:
 *
 * BiSS-C (iC-Haus BiSS C, as on Renishaw RESOLUTE and other single-turn
 * absolute encoders; unidirectional "sensor data" frame). The line idles
 * high; after the master's first clocks the slave pulls it low (Ack, one or
 * more clocks while it latches the position), then sends
 *
 *     Start (1) | CDS (the control-data bit, either level) |
 *     position, `bits` bits, MSB first | nE (error, active low) |
 *     nW (warning, active low) | CRC, 6 bits, MSB first, inverted
 *
 * and holds the line low (the timeout) before idling high again. The CRC
 * covers position, nE and nW: polynomial x^6 + x + 1 (0x43 with the x^6 term),
 * initial value 0, no reflection, transmitted inverted (xor 0x3F).
 *
 * SSI (synchronous serial interface, single transmission). The line idles
 * high; the first clock edge latches the position, so the first sample is
 * the idle level 1; then the position, `bits` bits, MSB first, in natural
 * binary or in Gray code; after the LSB the encoder holds the line low for
 * its monoflop time, so the sample after the LSB is 0:
 *
 *     1 | position, `bits` bits, MSB first | 0
 *
 * SSI carries no check value: a flipped data bit cannot be detected. Only a
 * stuck or absent line and the two fixed bits are checked (FRAMING).
 *
 * Faults (AACMM_ENC_FAULT_*, aacmm/proto.h), checked in this order:
 *   TIMEOUT     the interface got no answer (n_bits 0)
 *   STUCK_HIGH  every sample 1: nothing drives the line (no encoder, open wire)
 *   STUCK_LOW   every sample 0: the line is shorted low
 *   TIMEOUT     BiSS: no start bit after the Ack; either: the capture ends
 *               before the frame does
 *   FRAMING     SSI: the leading 1 or the trailing 0 is wrong
 *   CRC         BiSS: the CRC does not match
 *   ERROR_BIT   BiSS: nE = 0, the encoder says its position is not valid
 * A BiSS warning (nW = 0: e.g. a dirty scale) does not discard the position;
 * it is reported in *warning.
 *
 * No heap, no global state, integer only. Cost: O(n_bits).
 */
#ifndef AACMM_ENCODER_FRAME_H
#define AACMM_ENCODER_FRAME_H

#include <stdint.h>

#include "aacmm/proto.h" /* AACMM_ENC_* interface and fault codes */
#include "aacmm/status.h"

#ifdef __cplusplus
extern "C" {
#endif

#define AACMM_ENC_FRAME_MAX_BITS 96u /* clocks one frame can hold */
#define AACMM_ENC_BITS_MAX 32u       /* position bits per joint */
#define AACMM_BISS_CRC_POLY 0x03u    /* x^6 + x + 1 without the x^6 term */
#define AACMM_BISS_CRC_BITS 6u
/* Clocks a master gives per frame: BiSS: up to 6 before the start bit (lead
 * and Ack), start, CDS, position, nE, nW, CRC, and spare; SSI: 1 + bits + 1. */
#define AACMM_BISS_CLOCKS(bits) ((uint8_t)((bits) + 18u))
#define AACMM_SSI_CLOCKS(bits) ((uint8_t)((bits) + 2u))

/* The data-line samples of one frame: sample k (k = 0 .. n_bits-1) is bit
 * (7 - k % 8) of line[k / 8], i.e. MSB first, the first clock first. */
typedef struct {
    uint8_t line[AACMM_ENC_FRAME_MAX_BITS / 8u];
    uint8_t n_bits; /* samples taken; 0 = no answer. Above the maximum counts as the maximum */
} aacmm_enc_frame_t;

/* One joint's encoder interface. */
typedef struct {
    uint8_t interface; /* AACMM_ENC_BISS_C, AACMM_ENC_SSI_BINARY, AACMM_ENC_SSI_GRAY */
    uint8_t bits;      /* position bits, 1 .. AACMM_ENC_BITS_MAX */
} aacmm_enc_joint_config_t;

/* AACMM_OK if *cfg names a frame interface and 1..32 bits, else
 * AACMM_ERR_RANGE (AACMM_ERR_NULL for NULL). O(1). */
aacmm_status_t aacmm_enc_config_validate(const aacmm_enc_joint_config_t *cfg);

/* Clocks a master should give for one frame of *cfg (at most
 * AACMM_ENC_FRAME_MAX_BITS); 0 for an invalid configuration. O(1). */
uint8_t aacmm_enc_clocks(const aacmm_enc_joint_config_t *cfg);

/*
 * Decode one frame. Returns AACMM_ENC_FAULT_NONE with *position (< 2^bits)
 * and *warning (1 if the encoder set its warning bit, else 0), or the fault
 * (then *position is 0). An invalid configuration or a NULL argument gives
 * AACMM_ENC_FAULT_FRAMING. Reads only frame->line[0 .. (n_bits-1)/8].
 * Cost: O(n_bits).
 */
uint8_t aacmm_enc_decode(const aacmm_enc_joint_config_t *cfg, const aacmm_enc_frame_t *frame,
                         uint32_t *position, uint8_t *warning);

/*
 * The BiSS-C CRC-6 of the n (0..64) least significant bits of data, taken
 * MSB first: the remainder of data * x^6 divided by x^6 + x + 1, before the
 * inversion the frame applies. O(n).
 */
uint8_t aacmm_biss_crc6(uint64_t data, unsigned n);

/* Gray code to binary (each bit the xor of itself and all above it). O(1). */
uint32_t aacmm_gray_to_binary(uint32_t gray);

#ifdef __cplusplus
}
#endif

#endif /* AACMM_ENCODER_FRAME_H */
