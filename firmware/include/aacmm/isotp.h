/*
 * A small ISO-TP (ISO 15765-2) endpoint for classic CAN, normal addressing,
 * 11-bit ids: single frames, first/consecutive frames, flow control
 * (clear-to-send, wait, overflow), block size, STmin and timeouts. Messages
 * of 1 .. 4095 bytes (12-bit length; the escape for longer ones is not
 * supported). Frames are padded to 8 bytes with the configured byte.
 *
 * Poll-driven and single-threaded: the caller owns the state and buffers and
 * drives it with three calls from its main loop,
 *
 *     aacmm_isotp_on_frame(&tp, &rx_frame, now_ms);  for each received frame
 *     if (aacmm_isotp_receive(&tp, &msg, &len)) ...   a complete message
 *     while (can_tx_free() && aacmm_isotp_poll(&tp, now_ms, &tx)) can_send(&tx);
 *
 * and starts a transmission with aacmm_isotp_send. Time is a free-running
 * millisecond counter that may wrap. Anomalies are counted in tp.stats; the
 * library never clears them.
 *
 * The endpoint is half duplex per direction pair as in the standard: one
 * message being received and one being sent at a time. A new single or first
 * frame during a reception aborts the old one (counted) and starts over.
 */
#ifndef AACMM_ISOTP_H
#define AACMM_ISOTP_H

#include <stddef.h>
#include <stdint.h>

#include "aacmm/proto_can.h"
#include "aacmm/status.h"

#ifdef __cplusplus
extern "C" {
#endif

#define AACMM_ISOTP_MAX_LEN 4095u
#define AACMM_ISOTP_DEFAULT_TIMEOUT_MS 1000u /* N_Bs and N_Cr */
#define AACMM_ISOTP_DEFAULT_MAX_WAIT 10u     /* N_WFTmax */

typedef struct {
    uint32_t tx_id;      /* id this endpoint sends on, 0 .. 0x7FF */
    uint32_t rx_id;      /* id it listens on (data and flow control), 0 .. 0x7FF, != tx_id */
    uint8_t *rx_buf;     /* reassembly buffer, caller owned */
    size_t rx_cap;       /* its size, 1 .. 4095; longer messages are refused (FC overflow) */
    uint8_t *tx_buf;     /* holds a copy of the message being sent, caller owned */
    size_t tx_cap;       /* its size, 1 .. 4095 */
    uint8_t block_size;  /* BS we ask of the sender: CFs per flow control, 0 = no limit */
    uint8_t st_min;      /* STmin byte we ask for: 0x00..0x7F ms, 0xF1..0xF9 100..900 us */
    uint8_t padding;     /* pad byte for unused frame bytes (0xCC is usual) */
    uint8_t max_wait;    /* consecutive FC WAIT frames tolerated (N_WFTmax) */
    uint32_t timeout_ms; /* N_Bs (waiting for FC) and N_Cr (waiting for a CF), > 0 */
} aacmm_isotp_config_t;

/* Anomaly and traffic counters (incremented only, never cleared). */
typedef struct {
    uint32_t rx_messages;        /* messages completely received */
    uint32_t rx_bad_frames;      /* malformed frames (DLC, length field, PCI type) */
    uint32_t rx_sequence_errors; /* CF with the wrong sequence number: reception aborted */
    uint32_t rx_timeouts;        /* N_Cr expired: reception aborted */
    uint32_t rx_overflows;       /* FF longer than rx_cap: refused with FC overflow */
    uint32_t rx_interrupted;     /* reception replaced by a new SF/FF */
    uint32_t rx_unexpected;      /* CF while idle, FC while not waiting for one */
    uint32_t tx_messages;        /* messages completely sent */
    uint32_t tx_timeouts;        /* N_Bs expired waiting for FC */
    uint32_t tx_refused;         /* receiver answered FC overflow */
    uint32_t tx_aborted;         /* invalid FC or too many FC WAIT */
} aacmm_isotp_stats_t;

/* Endpoint state; fields other than stats are private. */
typedef struct {
    aacmm_isotp_config_t cfg;
    /* reception */
    uint8_t rx_state; /* 0 idle, 1 receiving, 2 message ready */
    size_t rx_len;
    size_t rx_pos;
    uint8_t rx_sn;
    uint8_t rx_block;
    uint32_t rx_deadline_ms;
    uint8_t fc_pending; /* 0 none, else FS + 1 */
    /* transmission */
    uint8_t tx_state; /* 0 idle, 1 send first/single, 2 wait FC, 3 sending CFs */
    size_t tx_len;
    size_t tx_pos;
    uint8_t tx_sn;
    uint8_t tx_bs;
    uint8_t tx_block;
    uint8_t tx_waits;
    uint32_t tx_stmin_ms;
    uint32_t tx_next_ms;
    uint32_t tx_deadline_ms;
    aacmm_status_t tx_result;
    aacmm_isotp_stats_t stats;
} aacmm_isotp_t;

/*
 * Initialise *tp from *cfg (copied) and zero the statistics.
 * AACMM_ERR_NULL (NULL tp, cfg or buffer), AACMM_ERR_RANGE (ids, capacities,
 * zero timeout, equal ids) or AACMM_OK. Cost: O(1).
 */
aacmm_status_t aacmm_isotp_init(aacmm_isotp_t *tp, const aacmm_isotp_config_t *cfg);

/*
 * Process one received CAN frame. Frames with another id than cfg.rx_id are
 * ignored. May queue a flow-control frame for aacmm_isotp_poll. Never reads
 * beyond frame->data[7] nor frame->dlc, never writes beyond rx_buf[rx_cap-1].
 * An unclaimed completed message is discarded when the next SF/FF arrives.
 * Cost: O(8).
 */
void aacmm_isotp_on_frame(aacmm_isotp_t *tp, const aacmm_can_frame_t *frame, uint32_t now_ms);

/*
 * If a complete message is waiting, set *data (inside cfg.rx_buf) and *len and
 * return 1 (once per message); the bytes stay valid until the next call of
 * aacmm_isotp_on_frame. Else return 0. Cost: O(1).
 */
int aacmm_isotp_receive(aacmm_isotp_t *tp, const uint8_t **data, size_t *len);

/*
 * Start sending data[0 .. len-1] (copied into cfg.tx_buf).
 * AACMM_ERR_BUSY if a transmission is in progress, AACMM_ERR_LENGTH if len is
 * 0 or above tx_cap or 4095, AACMM_ERR_NULL, else AACMM_OK. Cost: O(len).
 */
aacmm_status_t aacmm_isotp_send(aacmm_isotp_t *tp, const uint8_t *data, size_t len,
                                uint32_t now_ms);

/*
 * Advance timers and give the next frame to transmit now, if any: returns 1
 * and fills *out (dlc 8, padded), else 0. A returned frame counts as sent;
 * call only when the driver can take it. Flow control for reception goes
 * first. Cost: O(8).
 */
int aacmm_isotp_poll(aacmm_isotp_t *tp, uint32_t now_ms, aacmm_can_frame_t *out);

/*
 * The state of the last transmission: AACMM_ERR_BUSY while in progress,
 * AACMM_OK when done (or none yet), else why it failed (AACMM_ERR_TIMEOUT,
 * AACMM_ERR_OVERFLOW when the peer refused the length, AACMM_ERR_FRAME for
 * an invalid flow control or too many waits). O(1).
 */
aacmm_status_t aacmm_isotp_tx_result(const aacmm_isotp_t *tp);

#ifdef __cplusplus
}
#endif

#endif /* AACMM_ISOTP_H */
