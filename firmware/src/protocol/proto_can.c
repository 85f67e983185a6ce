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
                                       aacmm_can_frame_t frames[AACMM_CAN_SAMPLE_FRAMES])
{
    uint32_t n;
    if (s == NULL || frames == NULL) {
        return AACMM_ERR_NULL;
    }
    if (node_id > AACMM_CAN_NODE_ID_MAX) {
        return AACMM_ERR_RANGE;
    }
    n = node_id;
    put_pair(&frames[0], AACMM_CAN_ID_SAMPLE_HEADER + n, s->seq,
             (uint32_t)(s->timestamp_us & 0xFFFFFFFFu));
    put_pair(&frames[1], AACMM_CAN_ID_COUNTS_12 + n, s->counts[0], s->counts[1]);
    put_pair(&frames[2], AACMM_CAN_ID_COUNTS_34 + n, s->counts[2], s->counts[3]);
    put_pair(&frames[3], AACMM_CAN_ID_COUNTS_56 + n, s->counts[4], s->counts[5]);
    put_pair(&frames[4], AACMM_CAN_ID_POINT_XY + n, (uint32_t)s->point_100nm[0],
             (uint32_t)s->point_100nm[1]);
    put_pair(&frames[5], AACMM_CAN_ID_POINT_Z + n, (uint32_t)s->point_100nm[2],
             (s->status & 0xFFFFu) | ((s->seq & 0xFFu) << 16));
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
