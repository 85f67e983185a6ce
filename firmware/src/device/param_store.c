/*
 * Parameter storage: two slots, each one record with magic, format version,
 * generation and CRC (layout in aacmm/device.h). A save goes to the slot that
 * does not hold the newest valid record, so a power cut at any byte (or
 * during the erase of a flash page) keeps the previous good set. Every slot
 * is classified when read, so the device can say what it found.
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "aacmm/crc32.h"
#include "aacmm/device.h"
#include "aacmm/le_bytes.h"

#define OFF_MAGIC 0u
#define OFF_VERSION 4u
#define OFF_LEN 6u
#define OFF_GEN 8u
#define OFF_PAYLOAD 12u
#define OFF_CRC(len) (OFF_PAYLOAD + (len)) /* after a payload of len bytes */

#define NO_SLOT 0xFFu

aacmm_status_t aacmm_param_set_default(aacmm_param_set_t *set)
{
    if (set == NULL) {
        return AACMM_ERR_NULL;
    }
    memset(set, 0, sizeof *set);
    (void)aacmm_arm_default_f64(&set->arm);
    (void)aacmm_arm_encoders_default(&set->enc, AACMM_JOINTS);
    return AACMM_OK;
}

static int storage_usable(const aacmm_platform_t *pf)
{
    return pf->storage_read != NULL && pf->storage_write != NULL &&
           pf->storage_bytes >= AACMM_STORE_BYTES;
}

/* All record bytes equal to b. */
static int all_bytes(const uint8_t *rec, uint8_t b)
{
    size_t i;
    for (i = 0; i < AACMM_STORE_RECORD_BYTES; i++) {
        if (rec[i] != b) {
            return 0;
        }
    }
    return 1;
}

/* Decode and range-check the payload of a record whose CRC is good. */
static aacmm_status_t decode_payload(const uint8_t *rec, size_t len, aacmm_param_set_t *set)
{
    aacmm_status_t st = aacmm_param_set_decode(rec + OFF_PAYLOAD, len, set);
    if (st == AACMM_OK) {
        st = aacmm_arm_validate_f64(&set->arm);
    }
    if (st == AACMM_OK) {
        st = aacmm_arm_encoders_validate(&set->enc);
    }
    return st;
}

/* What the record bytes in rec are: AACMM_SLOT_OLDER for a valid record
 * (the caller ranks valid records), else the reason it is not one. When the
 * header is readable, *generation receives the generation field. *set is
 * scratch (the decoded set of a valid record). */
static uint8_t classify(const uint8_t *rec, uint32_t *generation, aacmm_param_set_t *set)
{
    uint16_t version;
    size_t len;
    *generation = 0u;
    if (all_bytes(rec, 0xFFu) || all_bytes(rec, 0x00u)) {
        return AACMM_SLOT_ERASED;
    }
    if (aacmm_le_get_u32(rec + OFF_MAGIC) != AACMM_STORE_MAGIC) {
        return AACMM_SLOT_UNRECOGNISED;
    }
    version = aacmm_le_get_u16(rec + OFF_VERSION);
    if (version == 0xFFFFu) {
        return AACMM_SLOT_INCOMPLETE; /* only the magic was written */
    }
    if (version != AACMM_STORE_VERSION) {
        return AACMM_SLOT_VERSION;
    }
    *generation = aacmm_le_get_u32(rec + OFF_GEN);
    len = aacmm_le_get_u16(rec + OFF_LEN);
    if (len < AACMM_PARAM_SET_HEADER_BYTES || len > AACMM_PARAM_SET_MAX_BYTES ||
        len != aacmm_msg_payload_len((uint8_t)AACMM_MSG_SET_PARAMS_REQ, rec + OFF_PAYLOAD, len)) {
        return AACMM_SLOT_BAD_LENGTH; /* not the length its set's header defines */
    }
    if (aacmm_crc32(rec, OFF_CRC(len)) != aacmm_le_get_u32(rec + OFF_CRC(len))) {
        return AACMM_SLOT_BAD_CRC;
    }
    if (decode_payload(rec, len, set) != AACMM_OK) {
        return AACMM_SLOT_BAD_CONTENTS;
    }
    return AACMM_SLOT_OLDER;
}

/* gen a newer than gen b (serial-number arithmetic, so it survives wrap). */
static int newer(uint32_t a, uint32_t b)
{
    return a != b && (uint32_t)(a - b) < 0x80000000u;
}

static int is_valid(uint8_t state)
{
    return state == AACMM_SLOT_NEWEST || state == AACMM_SLOT_OLDER;
}

static int is_bad(uint8_t state)
{
    return state != AACMM_SLOT_ERASED && !is_valid(state) && state != AACMM_SLOT_READ_ERROR;
}

/* Read and classify both slots into *r, ranking the valid ones. Returns 1 if
 * a read failed. */
static int scan(const aacmm_platform_t *pf, uint8_t *rec, aacmm_param_set_t *tmp,
                aacmm_store_report_t *r)
{
    uint8_t k;
    int io_error = 0;
    r->newest = NO_SLOT;
    for (k = 0; k < 2u; k++) {
        if (pf->storage_read(pf->ctx, (uint32_t)k * AACMM_STORE_SLOT_BYTES, rec,
                             AACMM_STORE_RECORD_BYTES) != AACMM_OK) {
            io_error = 1;
            r->slot_state[k] = AACMM_SLOT_READ_ERROR;
            r->slot_generation[k] = 0u;
            continue;
        }
        r->slot_state[k] = classify(rec, &r->slot_generation[k], tmp);
    }
    if (is_valid(r->slot_state[0]) && is_valid(r->slot_state[1])) {
        r->newest = newer(r->slot_generation[1], r->slot_generation[0]) ? 1u : 0u;
    } else if (is_valid(r->slot_state[0])) {
        r->newest = 0u;
    } else if (is_valid(r->slot_state[1])) {
        r->newest = 1u;
    }
    if (r->newest != NO_SLOT) {
        r->slot_state[r->newest] = AACMM_SLOT_NEWEST;
    }
    return io_error;
}

aacmm_status_t aacmm_store_load(const aacmm_platform_t *pf, aacmm_param_set_t *set,
                                uint8_t *state, aacmm_store_report_t *report,
                                uint32_t *bad_records, uint8_t record[AACMM_STORE_RECORD_BYTES])
{
    aacmm_store_report_t r;
    aacmm_param_set_t tmp;
    int io_error;
    int k;
    if (pf == NULL || set == NULL || state == NULL || record == NULL) {
        return AACMM_ERR_NULL;
    }
    r.slot_state[0] = r.slot_state[1] = AACMM_SLOT_ERASED;
    r.slot_generation[0] = r.slot_generation[1] = 0u;
    r.newest = NO_SLOT;
    if (!storage_usable(pf)) {
        *state = AACMM_STORAGE_EMPTY;
        if (report != NULL) {
            *report = r;
        }
        return AACMM_ERR_UNSUPPORTED;
    }
    io_error = scan(pf, record, &tmp, &r);
    if (r.newest != NO_SLOT) {
        /* Read the winner again into *set (tmp holds the last slot scanned). */
        uint32_t gen = 0u;
        if (pf->storage_read(pf->ctx, (uint32_t)r.newest * AACMM_STORE_SLOT_BYTES, record,
                             AACMM_STORE_RECORD_BYTES) != AACMM_OK) {
            io_error = 1;
            r.slot_state[r.newest] = AACMM_SLOT_READ_ERROR;
            r.newest = NO_SLOT;
        } else if (classify(record, &gen, &tmp) != AACMM_SLOT_OLDER ||
                   gen != r.slot_generation[r.newest]) {
            r.slot_state[r.newest] = AACMM_SLOT_BAD_CRC; /* changed under us */
            r.newest = NO_SLOT;
        } else {
            *set = tmp;
        }
    }
    if (bad_records != NULL) {
        *bad_records += (uint32_t)is_bad(r.slot_state[0]) + (uint32_t)is_bad(r.slot_state[1]);
    }
    if (report != NULL) {
        *report = r;
    }
    if (r.newest != NO_SLOT) {
        *state = AACMM_STORAGE_OK;
        return AACMM_OK;
    }
    *state = AACMM_STORAGE_EMPTY;
    for (k = 0; k < 2; k++) {
        if (r.slot_state[k] == AACMM_SLOT_VERSION && *state == AACMM_STORAGE_EMPTY) {
            *state = AACMM_STORAGE_VERSION;
        }
    }
    for (k = 0; k < 2; k++) {
        if (r.slot_state[k] != AACMM_SLOT_ERASED && r.slot_state[k] != AACMM_SLOT_VERSION) {
            *state = AACMM_STORAGE_CORRUPT;
        }
    }
    return io_error ? AACMM_ERR_IO : AACMM_ERR_STORAGE;
}

aacmm_status_t aacmm_store_save(const aacmm_platform_t *pf, const aacmm_param_set_t *set,
                                aacmm_store_report_t *report,
                                uint8_t record[AACMM_STORE_RECORD_BYTES])
{
    aacmm_store_report_t r;
    aacmm_param_set_t tmp;
    uint8_t target;
    uint32_t gen;
    uint32_t crc;
    uint32_t offset;
    size_t len = 0u;
    aacmm_status_t st;
    if (pf == NULL || set == NULL || record == NULL) {
        return AACMM_ERR_NULL;
    }
    if (!storage_usable(pf)) {
        return AACMM_ERR_UNSUPPORTED;
    }
    st = aacmm_param_set_encode(set, record + OFF_PAYLOAD, AACMM_PARAM_SET_MAX_BYTES, &len);
    if (st != AACMM_OK) {
        return st;
    }
    if (scan(pf, record, &tmp, &r)) {
        if (report != NULL) {
            *report = r;
        }
        return AACMM_ERR_IO;
    }
    target = r.newest == NO_SLOT ? 0u : (uint8_t)(1u - r.newest);
    gen = r.newest == NO_SLOT ? 1u : r.slot_generation[r.newest] + 1u;

    aacmm_le_put_u32(record + OFF_MAGIC, AACMM_STORE_MAGIC);
    aacmm_le_put_u16(record + OFF_VERSION, (uint16_t)AACMM_STORE_VERSION);
    aacmm_le_put_u16(record + OFF_LEN, (uint16_t)len);
    aacmm_le_put_u32(record + OFF_GEN, gen);
    (void)aacmm_param_set_encode(set, record + OFF_PAYLOAD, AACMM_PARAM_SET_MAX_BYTES, &len);
    crc = aacmm_crc32(record, OFF_CRC(len));
    aacmm_le_put_u32(record + OFF_CRC(len), crc);

    offset = (uint32_t)target * AACMM_STORE_SLOT_BYTES;
    /* From here on the target slot is neither its old contents nor the new
     * record until the read-back below says so. */
    r.slot_state[target] = AACMM_SLOT_BAD_CRC;
    r.slot_generation[target] = gen;
    if (report != NULL) {
        *report = r;
    }
    if (pf->storage_erase != NULL &&
        pf->storage_erase(pf->ctx, offset, AACMM_STORE_SLOT_BYTES) != AACMM_OK) {
        return AACMM_ERR_IO;
    }
    if (pf->storage_write(pf->ctx, offset, record, AACMM_STORE_RECORD_LEN(len)) != AACMM_OK) {
        return AACMM_ERR_IO;
    }
    /* Read back and check. */
    if (pf->storage_read(pf->ctx, offset, record, AACMM_STORE_RECORD_BYTES) != AACMM_OK) {
        return AACMM_ERR_IO;
    }
    {
        uint32_t g = 0u;
        if (classify(record, &g, &tmp) != AACMM_SLOT_OLDER || g != gen ||
            aacmm_le_get_u32(record + OFF_CRC(len)) != crc) {
            return AACMM_ERR_STORAGE;
        }
    }
    if (r.newest != NO_SLOT) {
        r.slot_state[r.newest] = AACMM_SLOT_OLDER;
    }
    r.slot_state[target] = AACMM_SLOT_NEWEST;
    r.newest = target;
    if (report != NULL) {
        *report = r;
    }
    return AACMM_OK;
}
