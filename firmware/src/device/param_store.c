/*
 * Parameter storage: two slots, each one record with magic, format version,
 * generation and CRC (layout in aacmm/device.h). A save goes to the slot that
 * does not hold the newest valid record, so a power cut at any byte keeps the
 * previous good set.
 */
#include <stddef.h>
#include <stdint.h>

#include "aacmm/crc32.h"
#include "aacmm/device.h"

#define OFF_MAGIC 0u
#define OFF_VERSION 4u
#define OFF_LEN 6u
#define OFF_GEN 8u
#define OFF_PAYLOAD 12u
#define OFF_CRC (OFF_PAYLOAD + AACMM_PARAM_SET_BYTES)

/* What one slot holds. */
enum { SLOT_EMPTY = 0, SLOT_VALID, SLOT_CORRUPT, SLOT_FOREIGN };

static uint32_t get_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

static uint16_t get_u16(const uint8_t *p)
{
    return (uint16_t)((uint16_t)p[0] | (uint16_t)((uint16_t)p[1] << 8));
}

static void put_u32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v & 0xFFu);
    p[1] = (uint8_t)((v >> 8) & 0xFFu);
    p[2] = (uint8_t)((v >> 16) & 0xFFu);
    p[3] = (uint8_t)((v >> 24) & 0xFFu);
}

static void put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)(v & 0xFFu);
    p[1] = (uint8_t)(v >> 8);
}

static int storage_usable(const aacmm_platform_t *pf)
{
    return pf->storage_read != NULL && pf->storage_write != NULL &&
           pf->storage_bytes >= AACMM_STORE_BYTES;
}

/* Classify the record in rec (header and CRC only). */
static int classify(const uint8_t *rec, uint32_t *generation)
{
    if (get_u32(rec + OFF_MAGIC) != AACMM_STORE_MAGIC) {
        return SLOT_EMPTY;
    }
    if (get_u16(rec + OFF_VERSION) != AACMM_STORE_VERSION) {
        return SLOT_FOREIGN;
    }
    if (get_u16(rec + OFF_LEN) != AACMM_PARAM_SET_BYTES ||
        aacmm_crc32(rec, OFF_CRC) != get_u32(rec + OFF_CRC)) {
        return SLOT_CORRUPT;
    }
    *generation = get_u32(rec + OFF_GEN);
    return SLOT_VALID;
}

/* Decode and range-check the payload of a valid record. */
static aacmm_status_t decode_payload(const uint8_t *rec, aacmm_param_set_t *set)
{
    aacmm_status_t st = aacmm_param_set_decode(rec + OFF_PAYLOAD, AACMM_PARAM_SET_BYTES, set);
    if (st == AACMM_OK) {
        st = aacmm_params_validate_f64(&set->kin);
    }
    if (st == AACMM_OK) {
        st = aacmm_encoder_validate(&set->enc);
    }
    return st;
}

/* gen a newer than gen b (serial-number arithmetic, so it survives wrap). */
static int newer(uint32_t a, uint32_t b)
{
    return a != b && (uint32_t)(a - b) < 0x80000000u;
}

typedef struct {
    int kind[2];
    uint32_t gen[2];
    int io_error;
} scan_t;

static void scan(const aacmm_platform_t *pf, uint8_t *rec, scan_t *s)
{
    uint8_t k;
    s->io_error = 0;
    for (k = 0; k < 2u; k++) {
        s->gen[k] = 0u;
        if (pf->storage_read(pf->ctx, (uint32_t)k * AACMM_STORE_SLOT_BYTES, rec,
                             AACMM_STORE_RECORD_BYTES) != AACMM_OK) {
            s->io_error = 1;
            s->kind[k] = SLOT_CORRUPT;
            continue;
        }
        s->kind[k] = classify(rec, &s->gen[k]);
    }
}

/* Slot of the newest valid record, or -1. */
static int newest(const scan_t *s)
{
    if (s->kind[0] == SLOT_VALID && s->kind[1] == SLOT_VALID) {
        return newer(s->gen[1], s->gen[0]) ? 1 : 0;
    }
    if (s->kind[0] == SLOT_VALID) {
        return 0;
    }
    if (s->kind[1] == SLOT_VALID) {
        return 1;
    }
    return -1;
}

aacmm_status_t aacmm_store_load(const aacmm_platform_t *pf, aacmm_param_set_t *set,
                                uint8_t *state, uint32_t *generation, uint8_t *slot,
                                uint32_t *bad_records, uint8_t record[AACMM_STORE_RECORD_BYTES])
{
    scan_t s;
    int order[2];
    int n = 0;
    int i;
    int first;
    int corrupt = 0;
    int foreign = 0;
    if (pf == NULL || set == NULL || state == NULL || record == NULL) {
        return AACMM_ERR_NULL;
    }
    if (!storage_usable(pf)) {
        *state = AACMM_STORAGE_EMPTY;
        return AACMM_ERR_UNSUPPORTED;
    }
    scan(pf, record, &s);
    /* Candidates, newest first. */
    first = newest(&s);
    if (first >= 0) {
        order[n++] = first;
        if (s.kind[1 - first] == SLOT_VALID) {
            order[n++] = 1 - first;
        }
    }
    for (i = 0; i < 2; i++) {
        if (s.kind[i] == SLOT_CORRUPT) {
            corrupt = 1;
        } else if (s.kind[i] == SLOT_FOREIGN) {
            foreign = 1;
        }
    }
    for (i = 0; i < n; i++) {
        int k = order[i];
        aacmm_param_set_t tmp;
        if (pf->storage_read(pf->ctx, (uint32_t)k * AACMM_STORE_SLOT_BYTES, record,
                             AACMM_STORE_RECORD_BYTES) != AACMM_OK) {
            s.io_error = 1;
            corrupt = 1;
            continue;
        }
        {
            uint32_t g = 0u;
            if (classify(record, &g) != SLOT_VALID || g != s.gen[k] ||
                decode_payload(record, &tmp) != AACMM_OK) {
                corrupt = 1;
                s.kind[k] = SLOT_CORRUPT;
                continue;
            }
        }
        *set = tmp;
        *state = AACMM_STORAGE_OK;
        if (generation != NULL) {
            *generation = s.gen[k];
        }
        if (slot != NULL) {
            *slot = (uint8_t)k;
        }
        if (bad_records != NULL) {
            *bad_records += (uint32_t)(s.kind[0] == SLOT_CORRUPT || s.kind[0] == SLOT_FOREIGN) +
                            (uint32_t)(s.kind[1] == SLOT_CORRUPT || s.kind[1] == SLOT_FOREIGN);
        }
        return AACMM_OK;
    }
    if (bad_records != NULL) {
        *bad_records += (uint32_t)(s.kind[0] == SLOT_CORRUPT || s.kind[0] == SLOT_FOREIGN) +
                        (uint32_t)(s.kind[1] == SLOT_CORRUPT || s.kind[1] == SLOT_FOREIGN);
    }
    if (corrupt) {
        *state = AACMM_STORAGE_CORRUPT;
    } else if (foreign) {
        *state = AACMM_STORAGE_VERSION;
    } else {
        *state = AACMM_STORAGE_EMPTY;
    }
    return s.io_error ? AACMM_ERR_IO : AACMM_ERR_STORAGE;
}

aacmm_status_t aacmm_store_save(const aacmm_platform_t *pf, const aacmm_param_set_t *set,
                                uint32_t *generation, uint8_t *slot,
                                uint8_t record[AACMM_STORE_RECORD_BYTES])
{
    scan_t s;
    int cur;
    int target;
    uint32_t gen;
    uint32_t crc;
    uint32_t offset;
    aacmm_status_t st;
    if (pf == NULL || set == NULL || record == NULL) {
        return AACMM_ERR_NULL;
    }
    if (!storage_usable(pf)) {
        return AACMM_ERR_UNSUPPORTED;
    }
    scan(pf, record, &s);
    if (s.io_error) {
        return AACMM_ERR_IO;
    }
    cur = newest(&s);
    target = cur < 0 ? 0 : 1 - cur;
    gen = cur < 0 ? 1u : s.gen[cur] + 1u;

    put_u32(record + OFF_MAGIC, AACMM_STORE_MAGIC);
    put_u16(record + OFF_VERSION, (uint16_t)AACMM_STORE_VERSION);
    put_u16(record + OFF_LEN, (uint16_t)AACMM_PARAM_SET_BYTES);
    put_u32(record + OFF_GEN, gen);
    st = aacmm_param_set_encode(set, record + OFF_PAYLOAD, AACMM_PARAM_SET_BYTES);
    if (st != AACMM_OK) {
        return st;
    }
    crc = aacmm_crc32(record, OFF_CRC);
    put_u32(record + OFF_CRC, crc);

    offset = (uint32_t)target * AACMM_STORE_SLOT_BYTES;
    if (pf->storage_write(pf->ctx, offset, record, AACMM_STORE_RECORD_BYTES) != AACMM_OK) {
        return AACMM_ERR_IO;
    }
    /* Read back and check. */
    if (pf->storage_read(pf->ctx, offset, record, AACMM_STORE_RECORD_BYTES) != AACMM_OK) {
        return AACMM_ERR_IO;
    }
    {
        uint32_t g = 0u;
        if (classify(record, &g) != SLOT_VALID || g != gen || get_u32(record + OFF_CRC) != crc) {
            return AACMM_ERR_STORAGE;
        }
    }
    if (generation != NULL) {
        *generation = gen;
    }
    if (slot != NULL) {
        *slot = (uint8_t)target;
    }
    return AACMM_OK;
}
