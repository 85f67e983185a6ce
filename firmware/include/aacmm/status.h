/*
 * aacmm status codes: one signed enum for the whole firmware.
 *
 * 0 is success; every error is negative. Functions that can fail return
 * aacmm_status_t; functions that cannot fail return their result directly.
 * Codes are stable: they travel over the link protocol, so a value is never
 * renumbered or reused (append new codes before AACMM_STATUS_MIN_).
 */
#ifndef AACMM_STATUS_H
#define AACMM_STATUS_H

#ifdef __cplusplus
extern "C" {
#endif

typedef enum {
    AACMM_OK = 0,
    AACMM_ERR_NULL = -1,         /* a required pointer argument is NULL */
    AACMM_ERR_RANGE = -2,        /* a value lies outside its documented range */
    AACMM_ERR_NOT_FINITE = -3,   /* a floating-point input is NaN or infinite */
    AACMM_ERR_BUFFER = -4,       /* a caller buffer is too small for the result */
    AACMM_ERR_CRC = -5,          /* a checksum did not match */
    AACMM_ERR_FRAME = -6,        /* malformed framing (bad delimiter, bad COBS, torn frame) */
    AACMM_ERR_LENGTH = -7,       /* a length field or payload size is wrong */
    AACMM_ERR_UNKNOWN_TYPE = -8, /* a message type or id this side does not know */
    AACMM_ERR_TIMEOUT = -9,      /* a peer did not answer in time */
    AACMM_ERR_BUSY = -10,        /* the resource is in use; try again later */
    AACMM_ERR_STORAGE = -11,     /* persistent storage failed or holds no valid record */
    AACMM_ERR_UNSUPPORTED = -12, /* the request is valid but this build does not support it */
    AACMM_ERR_STATE = -13,       /* the call is not valid in the current state */
    AACMM_ERR_OVERFLOW = -14,    /* a result does not fit its representation */
    AACMM_ERR_IO = -15,          /* a platform I/O function failed */
    AACMM_ERR_VERSION = -16,     /* the peer speaks another protocol or record version */
    AACMM_STATUS_MIN_ = -17      /* one below the lowest code; not a status */
} aacmm_status_t;

/*
 * A short, constant, human-readable name for a status code ("ok", "null
 * pointer", ...). Never returns NULL; unknown codes give "unknown status".
 * Cost: O(1).
 */
const char *aacmm_status_str(aacmm_status_t status);

#ifdef __cplusplus
}
#endif

#endif /* AACMM_STATUS_H */
