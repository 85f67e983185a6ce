/*
 * aacmm on classic CAN (11-bit identifiers, 8-byte frames).
 *
 * Every identifier is a base below plus the node id (0 .. AACMM_CAN_NODE_ID_MAX),
 * so up to 16 arms share one bus. The periodic sample frames are described
 * by host/src/aacmm/data/aacmm.dbc (for node 0); a host test checks that
 * file and this header against each other.
 *
 * One sample of an N-joint arm is AACMM_CAN_SAMPLE_FRAMES(N) frames (5 to
 * 7), queued back to back in this order (the device must transmit them
 * through one FIFO, so they stay in order on the bus):
 *
 *   0x100+n SampleHeader  Seq u32 | TimestampUs u32 (low 32 bits of the us clock)
 *   0x110+n Counts12      Count1 u32 | Count2 u32
 *   0x120+n Counts34      Count3 u32 | Count4 u32
 *   0x130+n Counts56      Count5 u32 | Count6 u32 (0 when N = 5)  only N >= 5
 *   0x170+n Counts7       Count7 u32 | Reserved u32 (0)           only N = 7
 *   0x140+n PointXY       X i32 | Y i32              (1e-4 mm per LSB)
 *   0x150+n PointZ        Z i32 | Status u16 (low 16 bits of the sample
 *                         status) | SeqTag u8 (Seq & 0xFF) | Joints u8 (N)
 *   0x160+n Trigger       Seq u32 (the sample latched at the edge) |
 *                         Button u8 | Pressed u8 | Reserved u16 (0)
 *
 * Requests, responses and events other than plain samples are message bodies
 * (aacmm/proto.h) carried by ISO-TP (aacmm/isotp.h), normal addressing:
 *   host -> device 0x600+n, device -> host 0x680+n.
 */
#ifndef AACMM_PROTO_CAN_H
#define AACMM_PROTO_CAN_H

#include <stddef.h>
#include <stdint.h>

#include "aacmm/proto.h"
#include "aacmm/status.h"

#ifdef __cplusplus
extern "C" {
#endif

#define AACMM_CAN_NODE_ID_MAX 15u

#define AACMM_CAN_ID_SAMPLE_HEADER 0x100u
#define AACMM_CAN_ID_COUNTS_12 0x110u
#define AACMM_CAN_ID_COUNTS_34 0x120u
#define AACMM_CAN_ID_COUNTS_56 0x130u
#define AACMM_CAN_ID_POINT_XY 0x140u
#define AACMM_CAN_ID_POINT_Z 0x150u
#define AACMM_CAN_ID_TRIGGER 0x160u
#define AACMM_CAN_ID_COUNTS_7 0x170u
#define AACMM_CAN_ID_ISOTP_REQUEST 0x600u  /* host -> device */
#define AACMM_CAN_ID_ISOTP_RESPONSE 0x680u /* device -> host */

#define AACMM_CAN_SAMPLE_FRAMES(n) (3u + ((n) + 1u) / 2u) /* N = 4..7: 5, 6, 6, 7 */
#define AACMM_CAN_SAMPLE_FRAMES_MAX 7u
#define AACMM_CAN_MAX_DLC 8u

/* One classic CAN frame (11-bit id). */
typedef struct {
    uint32_t id;                     /* 0 .. 0x7FF */
    uint8_t dlc;                     /* 0 .. 8 */
    uint8_t data[AACMM_CAN_MAX_DLC]; /* bytes beyond dlc are unspecified */
} aacmm_can_frame_t;

/*
 * Fill frames[0 .. *n_frames - 1] (AACMM_CAN_SAMPLE_FRAMES(s->joints)) with
 * sample *s for node node_id (0..15), in transmit order. Only the low 32
 * bits of the timestamp and the low 16 status bits are carried; the
 * Jacobian is not (use ISO-TP for that). AACMM_ERR_NULL, AACMM_ERR_RANGE
 * (node id, joints outside 4..7) or AACMM_OK. Cost: O(N).
 */
aacmm_status_t aacmm_can_sample_encode(const aacmm_sample_t *s, uint8_t node_id,
                                       aacmm_can_frame_t frames[AACMM_CAN_SAMPLE_FRAMES_MAX],
                                       size_t *n_frames);

/*
 * Fill *frame with a trigger frame: seq of the latched sample, button id,
 * pressed (0/1). AACMM_ERR_NULL, AACMM_ERR_RANGE (node id, pressed > 1) or
 * AACMM_OK. Cost: O(1).
 */
aacmm_status_t aacmm_can_trigger_encode(uint32_t seq, uint8_t button, uint8_t pressed,
                                        uint8_t node_id, aacmm_can_frame_t *frame);

#ifdef __cplusplus
}
#endif

#endif /* AACMM_PROTO_CAN_H */
