/*
 * Test-only helpers: read tests/vectors/protocol_vectors.txt and build the
 * expected C values of its named messages (the same values as
 * tests/vectors/gen_protocol_vectors.py, written out independently).
 */
#ifndef AACMM_TEST_VECTORS_H
#define AACMM_TEST_VECTORS_H

#include <stddef.h>
#include <stdint.h>

#include "aacmm/proto.h"

#define VEC_MAX_RECORDS 256
#define VEC_MAX_BYTES 1100
#define VEC_MAX_FRAMES 80

typedef struct {
    char kind[16];
    char name[48];
    uint8_t a[VEC_MAX_BYTES]; /* first hex field */
    size_t a_len;
    uint8_t b[VEC_MAX_BYTES]; /* second hex field (msg wire, crc value, can data) */
    size_t b_len;
    char word[32];            /* status / counter name */
    uint32_t id;              /* can / isotp id */
    uint8_t frames[VEC_MAX_FRAMES][8];
    size_t frame_len[VEC_MAX_FRAMES];
    size_t n_frames;
} vec_record_t;

/* Load every record; returns the count (aborts the test run on a bad file). */
size_t vec_load(const char *path, vec_record_t *records, size_t max);

/* Expected message for a "msg" record name; returns 0 if the name is unknown. */
int vec_expected_msg(const char *name, aacmm_msg_t *msg);

/* The SAMPLE_A values (used for CAN frames too). */
void vec_sample_a(aacmm_sample_t *s);

/* The parameter set of the vectors. */
void vec_params(aacmm_param_set_t *p);

/* Field-by-field equality of two decoded messages (floats compared bitwise). */
int vec_msg_equal(const aacmm_msg_t *x, const aacmm_msg_t *y);

/* aacmm_status_t from its enum name without the AACMM_ prefix ("ERR_CRC"). */
int vec_status_from_name(const char *name, aacmm_status_t *st);

#endif
