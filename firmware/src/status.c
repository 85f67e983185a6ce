#include "aacmm/status.h"

const char *aacmm_status_str(aacmm_status_t status)
{
    switch (status) {
    case AACMM_OK: return "ok";
    case AACMM_ERR_NULL: return "null pointer";
    case AACMM_ERR_RANGE: return "value out of range";
    case AACMM_ERR_NOT_FINITE: return "value not finite";
    case AACMM_ERR_BUFFER: return "buffer too small";
    case AACMM_ERR_CRC: return "checksum mismatch";
    case AACMM_ERR_FRAME: return "malformed frame";
    case AACMM_ERR_LENGTH: return "bad length";
    case AACMM_ERR_UNKNOWN_TYPE: return "unknown message type";
    case AACMM_ERR_TIMEOUT: return "timeout";
    case AACMM_ERR_BUSY: return "busy";
    case AACMM_ERR_STORAGE: return "storage error";
    case AACMM_ERR_UNSUPPORTED: return "unsupported";
    case AACMM_ERR_STATE: return "invalid state";
    case AACMM_ERR_OVERFLOW: return "overflow";
    case AACMM_ERR_IO: return "i/o error";
    case AACMM_ERR_VERSION: return "version mismatch";
    case AACMM_STATUS_MIN_: break;
    default: break;
    }
    return "unknown status";
}
