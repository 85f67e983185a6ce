/*
 * aacmm device application: the firmware of an arm controller, portable C99.
 *
 * One aacmm_device_t serves the link protocol (aacmm/proto.h, docs/protocol.md)
 * on both links at once, the serial link (COBS frames, aacmm/frame.h) and the
 * CAN link (periodic sample frames + ISO-TP, aacmm/proto_can.h), through the
 * board's platform table (aacmm/platform.h). It reads the encoders, computes
 * points and Jacobians with the kinematics core, answers every request,
 * streams samples at the requested rate and emits probe-button events. It
 * keeps the parameter set in the platform's storage as a double-buffered
 * record with a version and a CRC.
 *
 * No heap, no stdio, no global state: the caller owns the aacmm_device_t (and
 * the serial output queue it points to) and drives it from one thread:
 *
 *     aacmm_device_init(&dev, &config, &platform);
 *     for (;;) {
 *         aacmm_device_poll(&dev);
 *         sleep until aacmm_device_next_deadline_us(&dev) or link activity
 *     }
 *
 * Links. Each link has its own stream (rate, content, sequence numbers): a
 * STREAM_START received on the serial link streams SAMPLE_EVT frames on the
 * serial link; one received over ISO-TP streams on the CAN bus, as the six
 * periodic sample frames per sample, or -- when the Jacobian is asked for --
 * as SAMPLE_EVT messages over ISO-TP at up to AACMM_DEVICE_CAN_JAC_RATE_MAX_HZ
 * (the granted rate in STREAM_START_RSP says so).
 *
 * Sequence numbers. A stream's samples are numbered 0, 1, 2, ... from its
 * STREAM_START (a restart starts again at 0). A sample that cannot be sent
 * (output queue full, or the device fell more than max_catch_up periods
 * behind: after a shorter stall the missed samples are sent at once, each
 * read fresh) still uses its number, so the
 * host sees the gap; the next sample sent carries AACMM_SAMPLE_OVERRUN and
 * the loss is counted (aacmm_device_counters_t). MEASURE_RSP samples are
 * numbered by a device-wide measurement counter.
 *
 * Buttons. Two buttons (AACMM_BUTTON_CAPTURE = 0, AACMM_BUTTON_UNDO = 1,
 * read through the platform's read_buttons). Each edge of each button is
 * reported on every link with a sample read at the edge (docs/protocol.md
 * 2.7, one rule for both links): the sample carries AACMM_SAMPLE_TRIGGER_EVENT
 * and, as seq, the number the link's stream gives its next sample (so a
 * trigger lies between stream samples seq - 1 and seq and never uses up a
 * stream number). Serial: a TRIGGER_EVT, with the stream's Jacobian if it has
 * one. CAN (docs/protocol.md 4.1): the sample as six sample frames, then the
 * trigger frame naming its seq. Edges of several buttons seen in one poll are
 * reported in button order.
 *
 * Timestamps are the platform's time_us at the encoder reading.
 *
 * Link temperatures. With the platform's read_temperatures the device reads
 * them once per sample, after the encoders: a link of the arm model without
 * a valid reading in AACMM_REF_TEMP_MIN .. _MAX sets AACMM_SAMPLE_TEMP_FAULT
 * (counted: temp_faults). With the thermal block in force the point is
 * computed at the link temperatures (the scaled model is cached and
 * recomputed only when a temperature changes: N comparisons per sample
 * otherwise) and a sample with TEMP_FAULT has no point; without it the
 * point is that of a device without sensors, bit for bit. Without
 * read_temperatures the TEMPERATURES content and the thermal block are
 * AACMM_ERR_UNSUPPORTED. docs/architecture.md, "Link temperatures".
 *
 * Output. Serial output goes through a caller-owned byte queue of sample and
 * event bodies, framed one at a time into the device's frame buffer (the
 * stage) as the driver takes bytes. A request is only taken from the link
 * when the stage is empty and its response is framed straight into it, so a
 * response is never dropped and never waits behind queued samples (at most
 * behind the frame in progress). A stream sample or an event is dropped (and
 * counted) when it does not fit the queue; a stream sample that waited
 * longer than max_sample_age_ms is dropped instead of sent. CAN output goes
 * through a queue of AACMM_DEVICE_CAN_QUEUE frames; the six frames of a
 * sample are queued together or not at all.
 *
 * Parameter storage. Two slots of AACMM_STORE_SLOT_BYTES at storage offsets
 * 0 and AACMM_STORE_SLOT_BYTES, each holding one record:
 *
 *     offset  size  field
 *       0      4    magic AACMM_STORE_MAGIC, little-endian ("AACM")
 *       4      2    record format version AACMM_STORE_VERSION
 *       6      2    payload length L (8 .. AACMM_PARAM_SET_MAX_BYTES; 262 for
 *                   the paper's arm)
 *       8      4    generation, incremented by each save (wraps)
 *      12      L    parameter set, wire encoding (aacmm_param_set_encode,
 *                   docs/protocol.md 2.3: the arm model, its encoders and
 *                   the error model)
 *    12+L      4    CRC-32/ISO-HDLC of bytes 0 .. 11+L
 *
 * A save writes the AACMM_STORE_RECORD_LEN(L) bytes of its record; a load
 * reads AACMM_STORE_RECORD_BYTES (the largest record) and takes a record
 * only if L is the length its set's header defines (else BAD_LENGTH).
 *
 * Format version 2 (the arm model); a version 1 record (the six-joint set of
 * protocol version 1) reads as AACMM_SLOT_VERSION and is not used.
 *
 * A save writes the slot that does not hold the newest valid record, then
 * reads it back. A power cut at any byte leaves the other slot, the previous
 * good set, untouched; at start-up the newest valid record wins. When no
 * valid record exists the device runs on its defaults and says why in device
 * info (param_source DEFAULTS, storage_state EMPTY / CORRUPT / VERSION).
 *
 * Kinematics backend, chosen at build time: single-precision float core
 * (default) or, with -DAACMM_DEVICE_KIN_FIXED, the fixed-point core
 * (aacmm/kinematics_q.h); device info build_flags tell which
 * (AACMM_BUILD_KIN_FIXED). See firmware/src/device/device_kin.h.
 */
#ifndef AACMM_DEVICE_H
#define AACMM_DEVICE_H

#include <stddef.h>
#include <stdint.h>

#include "aacmm/encoder_frame.h"
#include "aacmm/frame.h"
#include "aacmm/isotp.h"
#include "aacmm/kinematics.h"
#include "aacmm/platform.h"
#include "aacmm/proto.h"
#include "aacmm/proto_can.h"
#include "aacmm/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Firmware version reported in device info. */
#define AACMM_FW_MAJOR 0u
#define AACMM_FW_MINOR 1u
#define AACMM_FW_PATCH 0u

/* ---- parameter storage record ---------------------------------------- */
#define AACMM_STORE_MAGIC 0x4D434141u /* "AACM" as little-endian bytes */
#define AACMM_STORE_VERSION 2u
#define AACMM_STORE_RECORD_BYTES (12u + AACMM_PARAM_SET_MAX_BYTES + 4u) /* 511: read */
#define AACMM_STORE_RECORD_LEN(len) (16u + (len)) /* written: a set of len bytes */
#define AACMM_STORE_SLOT_BYTES 512u
#define AACMM_STORE_BYTES (2u * AACMM_STORE_SLOT_BYTES) /* storage the device needs */

/* ---- sizes and timing -------------------------------------------------- */
/* Smallest serial output queue: room for two of the largest queued bodies
 * (each with its 6-byte header). Responses do not use it (they are framed
 * into the device's own frame buffer). 4 KiB or more is advisable for 1 kHz
 * streams with the Jacobian. */
#define AACMM_DEVICE_SERIAL_TXQ_MIN (2u * AACMM_FRAME_MAX_WIRE)
#define AACMM_DEVICE_CAN_QUEUE 64u      /* CAN frames queued in the device */
#define AACMM_DEVICE_CAN_JAC_RATE_MAX_HZ 100u /* CAN streams with Jacobian (ISO-TP) */
#define AACMM_DEVICE_MAX_CATCH_UP 64u   /* stream periods caught up after a stall */
#define AACMM_DEVICE_MAX_SAMPLE_AGE_MS 1000u /* serial samples older are dropped, not sent */
#define AACMM_DEVICE_IDLE_POLL_US 5000u /* longest sleep (button polling) */
#define AACMM_DEVICE_SERIAL_RX_CHUNK 128u
#define AACMM_DEVICE_SERIAL_RX_BYTES_PER_POLL (8u * AACMM_DEVICE_SERIAL_RX_CHUNK)
#define AACMM_DEVICE_CAN_RX_PER_POLL 32u

/* Links, as indices. */
#define AACMM_LINK_SERIAL 0u
#define AACMM_LINK_CAN 1u
#define AACMM_LINKS 2u

/* Configuration given to aacmm_device_init (copied; buffers are borrowed). */
typedef struct {
    uint32_t serial_number;            /* reported in device info */
    uint8_t can_node_id;               /* 0 .. AACMM_CAN_NODE_ID_MAX */
    const aacmm_param_set_t *defaults; /* built-in defaults (copied); NULL = the
                                          core's Table 1 arm with 2^32-count encoders
                                          (aacmm_param_set_default) */
    uint8_t *serial_txq;               /* serial output queue, caller owned, lives as
                                          long as the device; NULL if no serial link */
    size_t serial_txq_bytes;           /* >= AACMM_DEVICE_SERIAL_TXQ_MIN */
    uint32_t max_catch_up;             /* stream periods sent late after a stall
                                          before samples are skipped; 0 = default
                                          AACMM_DEVICE_MAX_CATCH_UP */
    uint32_t max_sample_age_ms;        /* a serial stream sample that waited longer
                                          in the output queue is dropped (counted,
                                          OVERRUN); 0 = AACMM_DEVICE_MAX_SAMPLE_AGE_MS */
    /* Start-up facts the port knows, reported in DIAG_RSP as given. */
    uint8_t reset_cause;               /* AACMM_RESET_* (0 = unknown) */
    uint32_t reset_raw;                /* the board's reset-reason register, 0 if none */
    uint32_t fault_pc;                 /* AACMM_RESET_FAULT: where the fault happened */
    uint32_t boot_count;               /* starts since power-up; 0 = not counted */
    uint16_t watchdog_ms;              /* the watchdog the port feeds; 0 = none */
    /* Each joint's encoder interface and position bits, used when the
     * platform provides read_encoder_frames (then every joint must be a
     * valid frame interface, aacmm_enc_config_validate). encoders[6] left
     * zero (interface COUNTS, bits 0) says the port has six encoders: a
     * 7-joint set is then refused with AACMM_ERR_UNSUPPORTED. */
    aacmm_enc_joint_config_t encoders[AACMM_JOINTS_MAX];
    /* 0: the port serves any joint count its encoders have (4 .. 6 or 7).
     * K (AACMM_JOINTS_MIN .. AACMM_JOINTS_MAX): it serves exactly K joints
     * (a simulator replaying a file of K joints), so SET_PARAMS of a set of
     * another joint count, and RESTORE_DEFAULTS to such defaults, are
     * refused with AACMM_ERR_UNSUPPORTED, the active set unchanged. The set
     * the device starts with is the port's to check (init does not refuse
     * it: the defaults are the fallback). Other values: AACMM_ERR_RANGE. */
    uint8_t joints_exact;
} aacmm_device_config_t;

/* What the two record slots held when last read (aacmm_store_load,
 * aacmm_store_save), as reported in DIAG_RSP. */
typedef struct {
    uint8_t slot_state[2];       /* AACMM_SLOT_* */
    uint32_t slot_generation[2]; /* generation field as read (0 without a readable header) */
    uint8_t newest;              /* slot of the newest valid record; 0xFF if none */
} aacmm_store_report_t;

/* Encoder input statistics of one joint (DIAG_RSP). */
typedef struct {
    uint8_t interface;  /* AACMM_ENC_* */
    uint8_t bits;
    uint8_t last_fault; /* AACMM_ENC_FAULT_* */
    uint32_t faults;
    uint32_t warnings;
} aacmm_device_joint_t;

/* Anomaly and traffic counters. The device increments them, never clears
 * them (they wrap at 2^32). Framing and ISO-TP counters live in the link
 * state (aacmm_device_serial_stats, aacmm_device_isotp_stats). */
typedef struct {
    uint32_t requests;          /* requests answered (either link, incl. errors) */
    uint32_t error_responses;   /* ERROR_RSP sent */
    uint32_t samples_sent;      /* stream samples queued for output */
    uint32_t samples_dropped;   /* stream samples lost: output queue full */
    uint32_t samples_late;      /* stream samples skipped: device fell behind */
    uint32_t samples_stale;     /* of samples_dropped: waited too long in the serial queue */
    uint32_t events_sent;       /* trigger events queued (per link) */
    uint32_t events_dropped;    /* trigger events lost: output queue full */
    uint32_t encoder_faults;    /* encoder reads that failed or gave counts >= cpr */
    uint32_t storage_errors;    /* storage read/write/verify failures */
    uint32_t storage_bad_records; /* records found corrupt or of another version */
    uint32_t serial_io_errors;  /* serial_read / serial_write failures */
    uint32_t can_io_errors;     /* can_send / can_receive failures */
    uint32_t can_frames_dropped; /* CAN frames not queued (device CAN queue full) */
    uint32_t can_rsp_dropped;   /* ISO-TP responses lost (previous one still sending) */
    uint32_t button_edges;      /* button presses + releases seen (all buttons) */
    uint32_t temp_faults;       /* samples with AACMM_SAMPLE_TEMP_FAULT (DIAG_RSP) */
} aacmm_device_counters_t;

/* ---- private state below: read only through the functions ------------- */

/* The kinematics backend's prepared model (build-time choice): the core's
 * model and the parameter set's error model in the backend's form;
 * corrected 0 when the set has none (every K_i 0): the plain core path, bit
 * for bit as before the error model. */
/* thermal 1 when the set has the thermal block (H = 1): its points are
 * computed at the link temperatures. The model at the last link
 * temperatures is kept beside it (aacmm_device_thermal_t, recomputed only
 * when a temperature changes). */
#if defined(AACMM_DEVICE_KIN_FIXED)
#include "aacmm/kinematics_q.h"
typedef struct {
    aacmm_model_q_t m;
    aacmm_errmodel_q_t em;
    uint8_t corrected;
    uint8_t thermal;
} aacmm_device_model_t;
typedef struct {
    aacmm_model_q_t m;                  /* the model's m at temp */
    int32_t temp_q8[AACMM_JOINTS_MAX];  /* temp in Q8 degC */
    int32_t e30[AACMM_JOINTS_MAX];      /* link i's cte_i (T_i - tref_i), Q30 */
    int16_t temp[AACMM_JOINTS_MAX];     /* AACMM_TEMP_UNIT_C, links 1..N */
    uint8_t valid;                      /* m is the active model at temp */
} aacmm_device_thermal_t;
#else
typedef struct {
    aacmm_model_f32_t m;
    aacmm_errmodel_f32_t em;
    uint8_t corrected;
    uint8_t thermal;
} aacmm_device_model_t;
typedef struct {
    aacmm_model_f32_t m;                /* the model's m at temp */
    float temp_c[AACMM_JOINTS_MAX];     /* temp in degC */
    float f[AACMM_JOINTS_MAX];          /* link i's length factor 1 + cte_i (T_i - tref_i) */
    int16_t temp[AACMM_JOINTS_MAX];     /* AACMM_TEMP_UNIT_C, links 1..N */
    uint8_t valid;                      /* m is the active model at temp */
} aacmm_device_thermal_t;
#endif

typedef struct {
    uint8_t active;
    uint8_t content;     /* AACMM_CONTENT_* delivered */
    uint8_t overrun;     /* set AACMM_SAMPLE_OVERRUN on the next sample sent */
    uint8_t sent_any;    /* a sample went out since STREAM_START */
    uint16_t rate_hz;
    uint32_t starts;     /* STREAM_START requests accepted on the link (wraps) */
    uint32_t seq;        /* seq of the next sample */
    uint32_t last_seq;   /* seq of the last sample sent */
    uint64_t start_us;   /* time of sample 0 */
    uint64_t index;      /* number of the next sample since start */
    uint64_t next_us;    /* its deadline */
} aacmm_device_stream_t;

typedef struct {
    uint8_t present;
    aacmm_deframer_t deframer;
    uint8_t *txq;    /* queued sample/event bodies, each behind a 6-byte header */
    size_t txq_cap;
    size_t txq_head; /* index of the oldest byte */
    size_t txq_len;
    size_t stage_len; /* the frame in progress, in the device's wire buffer */
    size_t stage_pos; /* bytes of it handed to the driver */
    uint8_t stale_overrun; /* stale samples dropped: flag the next one sent */
    uint8_t stage_sample;  /* the stage holds a stream sample ... */
    uint32_t stage_t_ms;   /* ... queued at this time */
    uint8_t rx[AACMM_DEVICE_SERIAL_RX_CHUNK];
    size_t rx_pos;
    size_t rx_len;
    aacmm_device_stream_t stream;
} aacmm_device_serial_t;

typedef struct {
    uint8_t present;
    uint8_t node_id;
    aacmm_isotp_t tp;
    uint8_t tp_rx[AACMM_PROTO_MAX_BODY];
    uint8_t tp_tx[AACMM_PROTO_MAX_BODY];
    aacmm_can_frame_t q[AACMM_DEVICE_CAN_QUEUE];
    size_t q_head;
    size_t q_len;
    uint8_t rsp[AACMM_PROTO_MAX_BODY]; /* response waiting for ISO-TP */
    size_t rsp_len;                    /* 0 = none */
    uint8_t evt[AACMM_PROTO_MAX_BODY]; /* SAMPLE_EVT (with Jacobian) waiting for ISO-TP */
    size_t evt_len;                    /* 0 = none */
    aacmm_device_stream_t stream;
} aacmm_device_can_t;

typedef struct {
    aacmm_platform_t pf;
    uint32_t serial_number;
    aacmm_param_set_t defaults;
    aacmm_param_set_t active;
    aacmm_device_model_t model;
    aacmm_device_thermal_t at_temp; /* the model at the last link temperatures */
    uint32_t active_crc32;
    uint8_t param_source;  /* AACMM_PARAM_SOURCE_* */
    uint8_t storage_state; /* AACMM_STORAGE_* */
    uint8_t storage_ok;    /* platform storage usable */
    uint8_t buttons;       /* last button levels, bit i = button i held */
    uint8_t event_seq;     /* header seq of device events */
    uint8_t reply_version; /* non-zero: the version byte of the ERROR_RSP being sent */
    uint8_t frame_joints;  /* encoders the port decodes frames of: 6 or 7 */
    uint8_t joints_exact;  /* aacmm_device_config_t.joints_exact */
    uint8_t have_stored;   /* a valid record exists; stored_crc32 is its set's CRC */
    uint32_t stored_crc32;
    aacmm_store_report_t store; /* the slots as last read or written */
    uint64_t start_us;
    uint8_t reset_cause;
    uint16_t watchdog_ms;
    uint32_t reset_raw;
    uint32_t fault_pc;
    uint32_t boot_count;
    aacmm_device_joint_t joints[AACMM_JOINTS_MAX];
    aacmm_enc_joint_config_t encoders[AACMM_JOINTS_MAX];
    aacmm_enc_frame_t frames[AACMM_JOINTS_MAX]; /* scratch of read_encoder_frames */
    uint32_t measure_seq;
    uint32_t max_catch_up;
    uint32_t max_sample_age_ms;
    aacmm_device_counters_t counters;
    aacmm_device_serial_t serial;
    aacmm_device_can_t can;
    /* scratch, kept here to keep the stack small on microcontrollers */
    aacmm_msg_t msg_in;
    aacmm_msg_t msg_out;
    uint8_t body[AACMM_PROTO_MAX_BODY];
    uint8_t wire[AACMM_FRAME_MAX_WIRE];
    uint8_t record[AACMM_STORE_RECORD_BYTES];
} aacmm_device_t;

/* ---- functions ----------------------------------------------------------- */

/*
 * Set up *dev: copy the platform table and config, load the parameter set
 * from storage (newest valid record, else the defaults; see above), prepare
 * the kinematics model and the links. No output is produced.
 * Returns AACMM_ERR_NULL (NULL argument, missing time_us or both encoder
 * functions, serial functions without a serial_txq), AACMM_ERR_RANGE (node
 * id, no link at all, serial_txq_bytes too small, invalid defaults, an
 * invalid joint configuration with read_encoder_frames), AACMM_ERR_BUFFER
 * never, else AACMM_OK -- also when storage is empty or corrupt (that is
 * reported in device info and the counters, not as an error).
 * Cost: two storage reads of AACMM_STORE_RECORD_BYTES, two CRCs, one model set-up.
 */
aacmm_status_t aacmm_device_init(aacmm_device_t *dev, const aacmm_device_config_t *config,
                                 const aacmm_platform_t *platform);

/*
 * Do all the work that is due now, without blocking: read and answer
 * requests on both links, send due stream samples, check the button, move
 * queued output to the drivers. Call it whenever a link has activity and at
 * aacmm_device_next_deadline_us at the latest.
 * Cost per call, worst case: AACMM_DEVICE_CAN_RX_PER_POLL CAN frames;
 * AACMM_DEVICE_SERIAL_RX_BYTES_PER_POLL received serial bytes, i.e. at most
 * that / 7 requests (each one deframe + decode + kinematics with Jacobian +
 * encode) and only while the output queue has room for a response; up to
 * max_catch_up stream samples per link (each one encoder read, one
 * temperature read + kinematics + encode; with the thermal block and a
 * changed temperature + one model scaling, 2N + 3 multiplies). AACMM_ERR_NULL for NULL, else AACMM_OK (link failures are
 * counted, never returned).
 */
aacmm_status_t aacmm_device_poll(aacmm_device_t *dev);

/*
 * Move queued output (serial bytes, CAN frames) to the drivers as far as they
 * take it, without reading requests or taking samples: for a clean shutdown.
 * AACMM_ERR_NULL or AACMM_OK. Cost: O(bytes and frames queued).
 */
aacmm_status_t aacmm_device_flush(aacmm_device_t *dev);

/*
 * The platform time by which aacmm_device_poll must run next: the earliest
 * stream deadline, ISO-TP timer, or now + AACMM_DEVICE_IDLE_POLL_US. A port
 * may also wake earlier on link activity. O(1). 0 for NULL.
 */
uint64_t aacmm_device_next_deadline_us(const aacmm_device_t *dev);

/* Bytes waiting in the serial output queue (the port should wait for the
 * serial line to be writable while this is > 0). O(1). */
size_t aacmm_device_serial_pending(const aacmm_device_t *dev);

/* 1 when the device will read received serial bytes at its next poll, 0
 * while the frame in progress waits for the driver (a request is only taken
 * when its answer can go out next): a port that sleeps on its serial line
 * should then wait for it to become writable, not readable. O(1). */
int aacmm_device_serial_wants_input(const aacmm_device_t *dev);

/* CAN frames waiting in the device CAN queue (wait for the bus to take
 * frames while > 0). O(1). */
size_t aacmm_device_can_pending(const aacmm_device_t *dev);

/* A link's stream as the device runs it (for ports and tools that watch the
 * device, e.g. the simulator's control channel). */
typedef struct {
    uint8_t active;   /* streaming now */
    uint8_t content;  /* AACMM_CONTENT_* of the running (or last) stream */
    uint16_t rate_hz; /* granted rate of the running (or last) stream */
    uint32_t starts;  /* STREAM_START requests accepted on this link since init (wraps):
                         a change means the host (re)started the stream */
    uint32_t next_seq; /* seq of the next stream sample (also a trigger's seq) */
} aacmm_device_stream_info_t;

/* Fill *info for link AACMM_LINK_SERIAL or AACMM_LINK_CAN (all zero for a
 * link the platform lacks). AACMM_ERR_NULL, AACMM_ERR_RANGE (unknown link) or
 * AACMM_OK. O(1). */
aacmm_status_t aacmm_device_stream_info(const aacmm_device_t *dev, unsigned link,
                                        aacmm_device_stream_info_t *info);

/* The device's counters (pointer into *dev, valid as long as it). O(1). */
const aacmm_device_counters_t *aacmm_device_counters(const aacmm_device_t *dev);

/* Serial deframer and ISO-TP counters (pointers into *dev). O(1). */
const aacmm_deframer_stats_t *aacmm_device_serial_stats(const aacmm_device_t *dev);
const aacmm_isotp_stats_t *aacmm_device_isotp_stats(const aacmm_device_t *dev);

/* Fill *info as the device answers INFO_REQ. AACMM_ERR_NULL or AACMM_OK. O(1). */
aacmm_status_t aacmm_device_info(const aacmm_device_t *dev, aacmm_msg_info_t *info);

/* Fill *diag as the device answers DIAG_REQ. AACMM_ERR_NULL or AACMM_OK. O(1). */
aacmm_status_t aacmm_device_diag(const aacmm_device_t *dev, aacmm_msg_diag_t *diag);

/* AACMM_BUILD_* flags of this build and platform (kinematics backend,
 * Jacobian, the links present). O(1). */
uint32_t aacmm_device_build_flags(const aacmm_device_t *dev);

/* ---- parameter storage, usable alone (tools, tests, boards) -------------- */

/* The built-in default set of a device without config->defaults: the
 * paper's arm (Table 1) with 2^32-count encoders and no error model.
 * AACMM_ERR_NULL or AACMM_OK. */
aacmm_status_t aacmm_param_set_default(aacmm_param_set_t *set);

/*
 * Load the newest valid record from the platform's storage into *set (decoded
 * and range-checked: aacmm_param_set_decode, aacmm_arm_validate_f64 and
 * aacmm_arm_encoders_validate).
 * *state (AACMM_STORAGE_*) sums up what was found: OK, EMPTY (both slots
 * erased), CORRUPT (no valid record, and a slot holds something that is not
 * one: damaged, cut, unrecognised or unreadable), VERSION (no valid record,
 * a record of another format version, nothing worse). *report (may be NULL)
 * receives each slot's state (AACMM_SLOT_*: which one is the newest, and why
 * the other was not taken) and generation. *bad_records (may be NULL) is
 * incremented for each slot that holds something other than an erased area,
 * a valid record or an unreadable one. *record is scratch of
 * AACMM_STORE_RECORD_BYTES. Returns AACMM_OK when a record was loaded,
 * AACMM_ERR_STORAGE when none (then *set is untouched), AACMM_ERR_IO when a
 * read failed and no record was loaded, AACMM_ERR_NULL,
 * AACMM_ERR_UNSUPPORTED (no storage functions or storage_bytes too small).
 * Cost: three reads of AACMM_STORE_RECORD_BYTES, up to three CRCs and decodes.
 */
aacmm_status_t aacmm_store_load(const aacmm_platform_t *pf, aacmm_param_set_t *set,
                                uint8_t *state, aacmm_store_report_t *report,
                                uint32_t *bad_records, uint8_t record[AACMM_STORE_RECORD_BYTES]);

/*
 * Save *set as a new record with the next generation, into the slot that
 * does not hold the newest valid record (storage_erase first, if the
 * platform has it), then read it back and check it. *report (may be NULL)
 * receives the slots' states afterwards (on failure the target slot reads
 * AACMM_SLOT_BAD_CRC). Returns AACMM_OK, AACMM_ERR_NULL,
 * AACMM_ERR_UNSUPPORTED (no storage), AACMM_ERR_NOT_FINITE / AACMM_ERR_RANGE
 * (set not encodable), AACMM_ERR_IO (erase, write or read failed),
 * AACMM_ERR_STORAGE (read-back differs). On error the previous record is
 * intact. Cost: one erase, one write and three reads of
 * AACMM_STORE_RECORD_BYTES, three CRCs and decodes.
 */
aacmm_status_t aacmm_store_save(const aacmm_platform_t *pf, const aacmm_param_set_t *set,
                                aacmm_store_report_t *report,
                                uint8_t record[AACMM_STORE_RECORD_BYTES]);

#ifdef __cplusplus
}
#endif

#endif /* AACMM_DEVICE_H */
