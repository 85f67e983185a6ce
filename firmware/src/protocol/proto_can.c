#include "aacmm/proto_can.h"

#include "aacmm/le_bytes.h"

static void put_pair(aacmm_can_frame_t *f, uint32_t id, uint32_t a, uint32_t b)
{
    f->id = id;
    f->dlc = 8u;
    aacmm_le_put_u32(&f->data[0], a);
    aacmm_le_put_u32(&f->data[4], b);
}

aacmm_status_t aacmm_can_sample_encode(const aacmm_sample_t *s, uint8_t node_id,
                                       aacmm_can_frame_t frames[AACMM_CAN_SAMPLE_FRAMES_MAX],
                                       size_t *n_frames)
{
    uint32_t n;
    size_t k = 0u;
    if (s == NULL || frames == NULL || n_frames == NULL) {
        return AACMM_ERR_NULL;
    }
    *n_frames = 0u;
    if (node_id > AACMM_CAN_NODE_ID_MAX || s->joints < (uint8_t)AACMM_JOINTS_MIN ||
        s->joints > (uint8_t)AACMM_JOINTS_MAX) {
        return AACMM_ERR_RANGE;
    }
    n = node_id;
    put_pair(&frames[k++], AACMM_CAN_ID_SAMPLE_HEADER + n, s->seq,
             (uint32_t)(s->timestamp_us & 0xFFFFFFFFu));
    put_pair(&frames[k++], AACMM_CAN_ID_COUNTS_12 + n, s->counts[0], s->counts[1]);
    put_pair(&frames[k++], AACMM_CAN_ID_COUNTS_34 + n, s->counts[2], s->counts[3]);
    if (s->joints >= 5u) {
        put_pair(&frames[k++], AACMM_CAN_ID_COUNTS_56 + n, s->counts[4],
                 s->joints >= 6u ? s->counts[5] : 0u);
    }
    if (s->joints >= 7u) {
        put_pair(&frames[k++], AACMM_CAN_ID_COUNTS_7 + n, s->counts[6], 0u);
    }
    put_pair(&frames[k++], AACMM_CAN_ID_POINT_XY + n, (uint32_t)s->point_100nm[0],
             (uint32_t)s->point_100nm[1]);
    put_pair(&frames[k++], AACMM_CAN_ID_POINT_Z + n, (uint32_t)s->point_100nm[2],
             (s->status & 0xFFFFu) | ((s->seq & 0xFFu) << 16) | ((uint32_t)s->joints << 24));
    *n_frames = k;
    return AACMM_OK;
}

aacmm_status_t aacmm_can_trigger_encode(uint32_t seq, uint8_t button, uint8_t pressed,
                                        uint8_t node_id, aacmm_can_frame_t *frame)
{
    if (frame == NULL) {
        return AACMM_ERR_NULL;
    }
    if (node_id > AACMM_CAN_NODE_ID_MAX || pressed > 1u) {
        return AACMM_ERR_RANGE;
    }
    put_pair(frame, AACMM_CAN_ID_TRIGGER + node_id, seq,
             (uint32_t)button | ((uint32_t)pressed << 8));
    return AACMM_OK;
}
