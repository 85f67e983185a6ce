/*
 * aacmm link protocol, version 4: the message set shared by the device and
 * the host (docs/protocol.md is the specification; this header is its C form).
 *
 * A message body is a 3-byte header followed by a type-specific payload, all
 * little-endian, no padding:
 *
 *     byte 0  protocol version (AACMM_PROTO_VERSION)
 *     byte 1  message type (aacmm_msg_type_t)
 *     byte 2  sequence number: chosen by the host in a request and echoed in
 *             the response (or error); device events carry their own counter
 *
 * The body travels in a serial frame (aacmm/frame.h) or as one ISO-TP message
 * on CAN (aacmm/isotp.h). Requests are 0x01..0x3F, unsolicited device events
 * 0x40..0x7F, the response to request t is t | 0x80, and any request may be
 * answered by AACMM_MSG_ERROR_RSP instead.
 *
 * Codec rules (the decoder enforces all; the encoder refuses to produce a
 * message the decoder would reject, so encode -> decode always round trips):
 *   - the payload length is exactly the one the type defines (AACMM_ERR_LENGTH)
 *   - every floating-point field is finite (AACMM_ERR_NOT_FINITE)
 *   - content/flag bytes have no unknown bits, reserved bytes are zero,
 *     enumerations are in range (AACMM_ERR_RANGE)
 *   - a parameter set's shape passes aacmm_shape_validate and its encoders
 *     aacmm_arm_encoders_validate (AACMM_ERR_RANGE): the core owns those rules
 *     (aacmm/kinematics.h, shape.c, encoder.c), so the codec, the device and
 *     the core apply one check. They are the codec's only dependencies beyond
 *     the protocol folder and status.c: integer-only and stateless, with no
 *     floating point and no other unit behind them.
 *   - the length of a payload follows from its own bytes (content, N, P, and
 *     for a parameter set K and the thermal flag), read before any range is
 *     checked: a wrong length is AACMM_ERR_LENGTH whatever those bytes hold.
 *   - an unknown type gives AACMM_ERR_UNKNOWN_TYPE, another version
 *     AACMM_ERR_VERSION (in both cases msg->type and msg->seq are still set
 *     from the header, so the device can answer with an error response).
 *
 * No heap, no global state, reentrant. The caller owns every buffer.
 */
#ifndef AACMM_PROTO_H
#define AACMM_PROTO_H

#include <stddef.h>
#include <stdint.h>

#include "aacmm/kinematics.h"
#include "aacmm/status.h"

#ifdef __cplusplus
extern "C" {
#endif

#define AACMM_PROTO_VERSION 4u
/* Older versions: 3 (the error model, before device temperatures), 2 (the
 * arm model, with the error-model block reserved in an earlier layout) and
 * 1 (six joints, 25 parameters). A body of version
 * AACMM_PROTO_VERSION_OLDEST .. AACMM_PROTO_VERSION_PREVIOUS is answered
 * with ERROR_RSP ERR_VERSION encoded in the body's own version (ERROR_RSP
 * has the same layout in all four), so an old host reads a clear version
 * error instead of a body it cannot decode (docs/protocol.md 6). */
#define AACMM_PROTO_VERSION_PREVIOUS 3u
#define AACMM_PROTO_VERSION_OLDEST 1u
#define AACMM_PROTO_HEADER_BYTES 3u
#define AACMM_PROTO_MAX_BODY 512u /* equals AACMM_FRAME_MAX_BODY */

/* Message types. Values are wire values and never change. */
typedef enum {
    AACMM_MSG_PING_REQ = 0x01,             /* u32 token */
    AACMM_MSG_INFO_REQ = 0x02,             /* empty */
    AACMM_MSG_GET_PARAMS_REQ = 0x03,       /* empty */
    AACMM_MSG_SET_PARAMS_REQ = 0x04,       /* parameter set (8 + 8P + 9N + ... bytes, 2.3) */
    AACMM_MSG_SAVE_PARAMS_REQ = 0x05,      /* empty: store the active set */
    AACMM_MSG_RESTORE_DEFAULTS_REQ = 0x06, /* empty: activate the built-in defaults */
    AACMM_MSG_MEASURE_REQ = 0x07,          /* u8 content */
    AACMM_MSG_COMPUTE_REQ = 0x08,          /* u8 content, u8 N, u32 counts[N] (, i16 temp[N]) */
    AACMM_MSG_STREAM_START_REQ = 0x09,     /* u16 rate_hz, u8 content */
    AACMM_MSG_STREAM_STOP_REQ = 0x0A,      /* empty */
    AACMM_MSG_DIAG_REQ = 0x0B,             /* empty: device diagnostics */

    AACMM_MSG_SAMPLE_EVT = 0x40,  /* streamed sample (same layout as MEASURE_RSP) */
    AACMM_MSG_TRIGGER_EVT = 0x41, /* probe button edge with the sample taken at it */

    AACMM_MSG_PING_RSP = 0x81,             /* u32 token (echo) */
    AACMM_MSG_INFO_RSP = 0x82,             /* device info (25 bytes) */
    AACMM_MSG_GET_PARAMS_RSP = 0x83,       /* parameter set (8 + 8P + 9N bytes) */
    AACMM_MSG_SET_PARAMS_RSP = 0x84,       /* u32 param_crc32 of the now active set */
    AACMM_MSG_SAVE_PARAMS_RSP = 0x85,      /* u32 param_crc32 of the stored set */
    AACMM_MSG_RESTORE_DEFAULTS_RSP = 0x86, /* u32 param_crc32 of the now active set */
    AACMM_MSG_MEASURE_RSP = 0x87,          /* sample (31 + 4N, + 2N temps, + 12P Jacobian) */
    AACMM_MSG_COMPUTE_RSP = 0x88,          /* compute result (30, + 12P with Jacobian) */
    AACMM_MSG_STREAM_START_RSP = 0x89,     /* u16 rate_hz accepted, u8 content */
    AACMM_MSG_STREAM_STOP_RSP = 0x8A,      /* empty */
    AACMM_MSG_DIAG_RSP = 0x8B,             /* diagnostics (64 + 11N bytes) */

    AACMM_MSG_ERROR_RSP = 0xFF /* i16 status (aacmm_status_t), u8 request type */
} aacmm_msg_type_t;

#define AACMM_MSG_RESPONSE_BIT 0x80u

/* Content flags (MEASURE_REQ, COMPUTE_REQ, STREAM_START_REQ, samples). */
#define AACMM_CONTENT_JACOBIAN 0x01u /* append the 3 x P Jacobian (float32) */
/* samples: the N link temperatures follow the counts (i16, AACMM_TEMP_UNIT_C,
 * AACMM_TEMP_NONE for a link without a reading); COMPUTE_REQ: the N link
 * temperatures to compute at follow the counts (COMPUTE_RSP echoes the bit,
 * no extra bytes). A device without sensors (no AACMM_BUILD_TEMPERATURES)
 * refuses it in MEASURE_REQ and STREAM_START_REQ with AACMM_ERR_UNSUPPORTED.
 * Both bits on a sample that would exceed the body (N 7, P 37) are
 * AACMM_ERR_RANGE. docs/protocol.md 2.4, 2.5. */
#define AACMM_CONTENT_TEMPERATURES 0x02u
#define AACMM_CONTENT_KNOWN 0x03u /* any other bit: AACMM_ERR_RANGE */

/* Sample status flags (u32; unknown bits are passed through, not rejected). */
#define AACMM_SAMPLE_POINT_VALID 0x0001u    /* point (and Jacobian) computed */
#define AACMM_SAMPLE_ENCODER_FAULT 0x0002u  /* an encoder read failed */
#define AACMM_SAMPLE_TRIGGER_DOWN 0x0004u   /* capture button (0) held at sample time */
#define AACMM_SAMPLE_PARAMS_DEFAULT 0x0008u /* running on built-in default parameters */
#define AACMM_SAMPLE_POINT_CLIPPED 0x0010u  /* point outside the int32 range; clamped */
#define AACMM_SAMPLE_OVERRUN 0x0020u        /* samples were dropped before this one */
#define AACMM_SAMPLE_ENCODER_WARNING 0x0040u /* an encoder flagged a warning; point valid */
/* Joint 1..7 gave no reading (its fault kind is counted in the diagnostics). */
#define AACMM_SAMPLE_JOINT1_FAULT 0x0100u
#define AACMM_SAMPLE_JOINT2_FAULT 0x0200u
#define AACMM_SAMPLE_JOINT3_FAULT 0x0400u
#define AACMM_SAMPLE_JOINT4_FAULT 0x0800u
#define AACMM_SAMPLE_JOINT5_FAULT 0x1000u
#define AACMM_SAMPLE_JOINT6_FAULT 0x2000u
#define AACMM_SAMPLE_JOINT7_FAULT 0x4000u
#define AACMM_SAMPLE_JOINT_FAULT(j) (AACMM_SAMPLE_JOINT1_FAULT << (j)) /* j = 0..6 */
#define AACMM_SAMPLE_JOINT_FAULTS 0x7F00u /* any joint */
/* A link temperature of the arm's N links was missing (the sensor did not
 * answer) or outside AACMM_REF_TEMP_MIN .. AACMM_REF_TEMP_MAX. With the
 * thermal block in force the sample then has no point (POINT_VALID clear);
 * without it the point is valid and only the temperatures are suspect. */
#define AACMM_SAMPLE_TEMP_FAULT 0x8000u
#define AACMM_SAMPLE_TRIGGER_EVENT 0x0080u /* read at a button edge: the sample of a trigger
                                              event, never a stream sample (docs/protocol.md 2.7) */

/* Buttons: the index carried by TRIGGER_EVT and the CAN trigger frame. */
#define AACMM_BUTTON_CAPTURE 0u /* the probe (front) button: take a point */
#define AACMM_BUTTON_UNDO 1u    /* the second button: undo the last point */
#define AACMM_BUTTONS 2u        /* buttons a device reports */

/* Device info build_flags. */
#define AACMM_BUILD_KIN_FIXED 0x0001u  /* fixed-point kinematics (else floating point) */
#define AACMM_BUILD_KIN_F64 0x0002u    /* floating point is double precision (else float) */
#define AACMM_BUILD_JACOBIAN 0x0004u   /* Jacobian content supported */
#define AACMM_BUILD_SERIAL 0x0008u     /* serial transport built in */
#define AACMM_BUILD_CAN 0x0010u        /* CAN transport built in */
#define AACMM_BUILD_TEMPERATURES 0x0020u /* the platform reads link temperatures (known at run
                                            time: a board whose sensor did not answer at
                                            start-up has none) */

/* Device info param_source: where the active parameter set came from. */
#define AACMM_PARAM_SOURCE_DEFAULTS 0u /* the built-in defaults */
#define AACMM_PARAM_SOURCE_STORAGE 1u  /* loaded from storage, or saved since: a restart loads it */
#define AACMM_PARAM_SOURCE_HOST 2u     /* set by the host (SET_PARAMS), not saved: lost at restart */
#define AACMM_PARAM_SOURCE_MAX 2u
/* Device info storage_state. */
#define AACMM_STORAGE_OK 0u
#define AACMM_STORAGE_EMPTY 1u   /* no record found */
#define AACMM_STORAGE_CORRUPT 2u /* record CRC failed */
#define AACMM_STORAGE_VERSION 3u /* record of another format version */
#define AACMM_STORAGE_STATE_MAX 3u

/* ---- diagnostics (DIAG_RSP) ---------------------------------------------- */
/* storage_kind: where the parameter records live. */
#define AACMM_STORAGE_KIND_NONE 0u         /* no storage: SAVE_PARAMS is refused */
#define AACMM_STORAGE_KIND_RAM 1u          /* RAM: lost at every restart */
#define AACMM_STORAGE_KIND_RAM_RETAINED 2u /* RAM kept across resets, lost at power-off */
#define AACMM_STORAGE_KIND_FILE 3u         /* a file (the POSIX simulator) */
#define AACMM_STORAGE_KIND_FLASH 4u        /* the microcontroller's own flash pages */
#define AACMM_STORAGE_KIND_EEPROM 5u       /* an EEPROM or external flash chip */
#define AACMM_STORAGE_KIND_MAX 5u
/* storage_flags */
#define AACMM_STORAGE_PERSISTENT 0x01u /* the store survives power-off */
#define AACMM_STORAGE_FLAGS_KNOWN 0x01u
/* slot_state: what each of the two record slots held when last read. */
#define AACMM_SLOT_ERASED 0u       /* blank (never written): all 0xFF or all 0x00 */
#define AACMM_SLOT_NEWEST 1u       /* valid record, the newest: what a restart loads */
#define AACMM_SLOT_OLDER 2u        /* valid record, older: the fallback */
#define AACMM_SLOT_BAD_CRC 3u      /* record whose CRC fails (a cut save or damage) */
#define AACMM_SLOT_BAD_CONTENTS 4u /* CRC good, but the set is out of range */
#define AACMM_SLOT_VERSION 5u      /* record of another format version */
#define AACMM_SLOT_BAD_LENGTH 6u   /* record with another payload length */
#define AACMM_SLOT_INCOMPLETE 7u   /* record magic, header partly blank: a save cut early */
#define AACMM_SLOT_UNRECOGNISED 8u /* not blank and not a record: foreign data */
#define AACMM_SLOT_READ_ERROR 9u   /* the storage read failed */
#define AACMM_SLOT_STATE_MAX 9u
/* reset_cause: why the device last started. */
#define AACMM_RESET_UNKNOWN 0u   /* not recorded (a reset the board cannot tell apart) */
#define AACMM_RESET_POWER_ON 1u  /* power-up (the simulator: process start) */
#define AACMM_RESET_PIN 2u       /* the reset pin or a debugger */
#define AACMM_RESET_WATCHDOG 3u  /* the watchdog expired: the main loop stalled */
#define AACMM_RESET_SOFTWARE 4u  /* a software reset request (SYSRESETREQ) */
#define AACMM_RESET_FAULT 5u     /* a CPU fault (HardFault, lockup); fault_pc says where */
#define AACMM_RESET_CAUSE_MAX 5u
/* Encoder interface of a joint. */
#define AACMM_ENC_COUNTS 0u     /* counts from the port (no frame decoding) */
#define AACMM_ENC_BISS_C 1u     /* BiSS-C: ack, start, CDS, position, nE, nW, CRC-6 */
#define AACMM_ENC_SSI_BINARY 2u /* SSI, natural binary */
#define AACMM_ENC_SSI_GRAY 3u   /* SSI, Gray code */
#define AACMM_ENC_INTERFACE_MAX 3u
/* Joint fault kinds (last_fault): the reading was discarded. */
#define AACMM_ENC_FAULT_NONE 0u       /* no fault */
#define AACMM_ENC_FAULT_CRC 1u        /* the frame's CRC does not match */
#define AACMM_ENC_FAULT_ERROR_BIT 2u  /* the encoder reports an error (BiSS nE) */
#define AACMM_ENC_FAULT_STUCK_LOW 3u  /* the data line reads all zeros */
#define AACMM_ENC_FAULT_STUCK_HIGH 4u /* the data line reads all ones (nothing answers) */
#define AACMM_ENC_FAULT_TIMEOUT 5u    /* no start bit, or the frame ended early */
#define AACMM_ENC_FAULT_FRAMING 6u    /* frame bits that must be fixed are wrong (SSI) */
#define AACMM_ENC_FAULT_RANGE 7u      /* position >= the joint's counts per revolution */
#define AACMM_ENC_FAULT_READ 8u       /* the port's read failed */
#define AACMM_ENC_FAULT_MAX 8u

#define AACMM_STREAM_RATE_MIN_HZ 1u
#define AACMM_STREAM_RATE_MAX_HZ 1000u

/* Point on the wire: int32 in units of 100 nm (1e-4 mm), range +-214.7 m. */
#define AACMM_POINT_UNIT_MM 1e-4

/* Payload sizes in bytes. N joints (4..7), P parameters (Jacobian columns,
 * P = 4N + B + T, aacmm/kinematics.h), S = sum of the joints' encoder
 * harmonics K_i (0..4 each, so S <= 4N), H = 1 with the thermal block, else
 * 0; content is the AACMM_CONTENT_* byte. Every size a message can have is
 * at most AACMM_PROTO_MAX_BODY - AACMM_PROTO_HEADER_BYTES (509): the one
 * combination beyond it, a sample of N 7, P 37 with temperatures and
 * Jacobian (517), is refused (AACMM_SAMPLE_MAX_BYTES). */
#define AACMM_PARAM_SET_HEADER_BYTES 8u
#define AACMM_PARAM_SET_BYTES(n, p, s, h)                                                   \
    (AACMM_PARAM_SET_HEADER_BYTES + 8u * (p) + 9u * (n) + 4u * (s) + 2u * ((n) + 1u) * (h))
#define AACMM_PARAM_SET_PAPER_BYTES 262u /* the paper's arm: N 6, P 25, S 0, H 0 */
#define AACMM_PARAM_SET_MAX_BYTES 495u   /* N 7, P 37, K 4 on every joint (S 28), H 1 */
#define AACMM_INFO_BYTES 25u
#define AACMM_SAMPLE_BASE_BYTES 31u             /* before the N counts */
/* content: the sample's AACMM_CONTENT_* byte (a plain 1 still means Jacobian) */
#define AACMM_SAMPLE_BYTES(n, p, content)                                                   \
    (AACMM_SAMPLE_BASE_BYTES + 4u * (n) +                                                   \
     (((unsigned)(content) & AACMM_CONTENT_TEMPERATURES) ? 2u * (n) : 0u) +                \
     (((unsigned)(content) & AACMM_CONTENT_JACOBIAN) ? 12u * (p) : 0u))
/* The largest sample: N 7, P 36 with temperatures and Jacobian (N 7, P 37
 * with Jacobian alone is 503; with both it would be 517, more than a body
 * holds: the encoder refuses it with AACMM_ERR_RANGE). A TRIGGER_EVT adds
 * AACMM_TRIGGER_EXTRA_BYTES and still fits. */
#define AACMM_SAMPLE_MAX_BYTES 505u
#define AACMM_COMPUTE_REQ_BYTES(n, content)                                                 \
    (2u + 4u * (n) + (((unsigned)(content) & AACMM_CONTENT_TEMPERATURES) ? 2u * (n) : 0u))
#define AACMM_COMPUTE_RSP_BASE_BYTES 30u /* without Jacobian */
#define AACMM_COMPUTE_RSP_BYTES(p, jac) (AACMM_COMPUTE_RSP_BASE_BYTES + ((jac) ? 12u * (p) : 0u))
#define AACMM_TRIGGER_EXTRA_BYTES 2u     /* before the embedded sample */
#define AACMM_DIAG_JOINT_BYTES 11u
#define AACMM_DIAG_BASE_BYTES 60u
#define AACMM_DIAG_TAIL_BYTES 4u /* u32 temp_faults after the joints */
#define AACMM_DIAG_BYTES(n)                                                                 \
    (AACMM_DIAG_BASE_BYTES + (n) * AACMM_DIAG_JOINT_BYTES + AACMM_DIAG_TAIL_BYTES)

/* ---- the parameter set's error model (issue 27) ---------------------------
 * The core's error model (aacmm/kinematics.h, "Error model") as the wire
 * carries it: per joint K_i <= AACMM_HARMONICS_MAX encoder harmonics, the
 * joint angle error sum_k c_ik cos(k q) + s_ik sin(k q) added to the reading
 * (rad, before the theta offset); with the thermal block per link i = 1..N a
 * coefficient of thermal expansion and one reference temperature for every
 * link. Stored as i16 in the units below (a coefficient within +-3.2767
 * mrad, so a joint's sum stays far inside the core's 0.1 rad; |cte| within
 * 3.2767e-4 /K inside the core's 1e-3 /K). The header's u32 at offset 4
 * packs K_i in bits 4(i-1) .. 4(i-1)+3 and H in bit 28 (docs/protocol.md
 * 2.3). The device loads it into the core's aacmm_errmodel_f32_t /
 * aacmm_errmodel_q_t (every link's tref = ref_temp) and applies it to every
 * point it computes. */
#define AACMM_HARMONICS_MAX 4
#define AACMM_HARMONIC_UNIT_RAD 1e-7   /* c_k, s_k: +-3.2767 mrad in 0.1 urad */
#define AACMM_CTE_UNIT_PER_K 1e-8      /* +-3.2767e-4 / K in 1e-8 / K */
#define AACMM_TEMP_UNIT_C 0.01         /* reference temperature, 0.01 degC */
#define AACMM_REF_TEMP_MIN (-4000)     /* -40 degC: AACMM_TEMP_MIN_C */
#define AACMM_REF_TEMP_MAX 8500        /* 85 degC: AACMM_TEMP_MAX_C */
#define AACMM_PARAM_THERMAL_BIT 28u    /* H in the header's u32 at offset 4 */
/* A link temperature on the wire (samples, COMPUTE_REQ): i16 in
 * AACMM_TEMP_UNIT_C; AACMM_TEMP_NONE = no reading. */
#define AACMM_TEMP_NONE INT16_MIN

typedef struct {
    uint8_t harmonics[AACMM_JOINTS_MAX]; /* K_i, 0 .. AACMM_HARMONICS_MAX; 0 past N */
    uint8_t thermal;                     /* 1 if cte and ref_temp are present, else 0 */
    int16_t harm_cos[AACMM_JOINTS_MAX][AACMM_HARMONICS_MAX]; /* c_k of joint i, k = 1..K_i */
    int16_t harm_sin[AACMM_JOINTS_MAX][AACMM_HARMONICS_MAX]; /* s_k */
    int16_t cte[AACMM_JOINTS_MAX]; /* link i, 1e-8 / K */
    int16_t ref_temp; /* the temperature the lengths hold at, 0.01 degC, -4000 .. 8500 */
} aacmm_error_model_t;

typedef struct {
    uint32_t token; /* any value; echoed unchanged */
} aacmm_msg_ping_t;

typedef struct {
    uint16_t protocol_version; /* AACMM_PROTO_VERSION of the device */
    uint8_t fw_major;
    uint8_t fw_minor;
    uint16_t fw_patch;
    uint32_t build_flags;    /* AACMM_BUILD_* */
    uint32_t param_crc32;    /* aacmm_param_set_crc32 of the active set */
    uint8_t param_source;    /* AACMM_PARAM_SOURCE_* (0..2) */
    uint8_t storage_state;   /* AACMM_STORAGE_* (0..3) */
    uint16_t max_body_bytes; /* largest body the device accepts (<= 512) */
    uint32_t serial_number;
    uint8_t can_node_id; /* 0..15 */
    uint8_t joints;      /* N of the active arm model, 4..7 */
    uint8_t params;      /* P of the active arm model: Jacobian columns */
} aacmm_msg_info_t;

/* The parameter set carried by GET/SET_PARAMS and stored by the device: the
 * arm model (shape and values), its encoders and the error model. Layout:
 * docs/protocol.md 2.3. Entries past N (and past K) are 0; enc.joints is N. */
typedef struct {
    aacmm_arm_f64_t arm;      /* shape and values, mm and rad, all finite */
    aacmm_arm_encoders_t enc; /* cpr 2..2^32, zero offset < cpr, direction +-1 */
    aacmm_error_model_t err;  /* all 0: no correction (today's points, bit for bit) */
} aacmm_param_set_t;

typedef struct {
    uint32_t param_crc32;
} aacmm_msg_param_crc_t;

/* MEASURE_RSP and SAMPLE_EVT. */
typedef struct {
    uint32_t seq;                      /* sample counter, wraps */
    uint64_t timestamp_us;             /* device monotonic clock, us */
    int32_t point_100nm[3];            /* probe x, y, z in units of 1e-4 mm */
    uint32_t status;                   /* AACMM_SAMPLE_* */
    uint8_t content;                   /* AACMM_CONTENT_* present in this sample */
    uint8_t joints;                    /* N, 4..7 */
    uint8_t params;                    /* P, 4N + 1 .. 5N + 2 */
    uint32_t counts[AACMM_JOINTS_MAX]; /* raw encoder readings, joints 1..N */
    int16_t temp[AACMM_JOINTS_MAX];    /* links 1..N, AACMM_TEMP_UNIT_C or AACMM_TEMP_NONE,
                                          if content has TEMPERATURES (else 0); any i16 */
    float jacobian[AACMM_JAC_SIZE_MAX]; /* row-major 3 x P if content has JACOBIAN */
} aacmm_sample_t;

typedef struct {
    uint8_t content; /* AACMM_CONTENT_* wanted */
} aacmm_msg_measure_req_t;

typedef struct {
    uint8_t content;
    uint8_t joints; /* N, 4..7: must be the device's (else ERR_RANGE from the device) */
    uint32_t counts[AACMM_JOINTS_MAX];
    int16_t temp[AACMM_JOINTS_MAX]; /* if content has TEMPERATURES: links 1..N, AACMM_TEMP_UNIT_C,
                                       AACMM_REF_TEMP_MIN .. _MAX (else ERR_RANGE); else 0 */
} aacmm_msg_compute_req_t;

typedef struct {
    uint32_t status;                /* AACMM_SAMPLE_* (POINT_VALID etc.) */
    double point_mm[3];             /* the device's own result, mm, float64 */
    uint8_t content;                /* AACMM_CONTENT_* present; TEMPERATURES: computed at the
                                       request's temperatures (no extra bytes) */
    uint8_t params;                 /* P of the device's arm model */
    float jacobian[AACMM_JAC_SIZE_MAX]; /* row-major 3 x P if content has JACOBIAN */
} aacmm_msg_compute_rsp_t;

typedef struct {
    uint16_t rate_hz; /* AACMM_STREAM_RATE_MIN_HZ .. AACMM_STREAM_RATE_MAX_HZ */
    uint8_t content;  /* AACMM_CONTENT_* */
} aacmm_msg_stream_t;

typedef struct {
    uint8_t button;        /* AACMM_BUTTON_CAPTURE (0) or AACMM_BUTTON_UNDO (1) */
    uint8_t pressed;       /* 1 press, 0 release */
    aacmm_sample_t sample; /* read at the edge; seq = the link's next stream seq,
                              status has AACMM_SAMPLE_TRIGGER_EVENT */
} aacmm_msg_trigger_t;

/* One joint's encoder input in DIAG_RSP. */
typedef struct {
    uint8_t interface;  /* AACMM_ENC_* */
    uint8_t bits;       /* position bits 1..32; 0 for AACMM_ENC_COUNTS */
    uint8_t last_fault; /* AACMM_ENC_FAULT_* of the latest fault, NONE if none yet */
    uint32_t faults;    /* readings discarded since start-up */
    uint32_t warnings;  /* readings with the encoder's warning bit (still used) */
} aacmm_diag_joint_t;

/* DIAG_RSP: what a firmware engineer bringing up an arm needs to see. */
typedef struct {
    uint8_t storage_kind;        /* AACMM_STORAGE_KIND_* */
    uint8_t storage_flags;       /* AACMM_STORAGE_PERSISTENT */
    uint8_t slot_state[2];       /* AACMM_SLOT_* per record slot, as last read */
    uint32_t slot_generation[2]; /* each slot's generation field (0 when it has no header) */
    uint32_t storage_errors;     /* storage read/write/verify failures */
    uint32_t storage_bad_records; /* damaged, foreign or unrecognised slots found */
    uint8_t reset_cause;         /* AACMM_RESET_* */
    uint32_t reset_raw;          /* the board's reset-reason register as read, 0 if none */
    uint32_t fault_pc;           /* AACMM_RESET_FAULT: program counter of the fault */
    uint32_t boot_count;         /* starts since power-up, 1 = first; 0 = not counted */
    uint16_t watchdog_ms;        /* watchdog timeout, 0 = no watchdog */
    uint64_t uptime_us;          /* time since start-up */
    uint32_t encoder_faults;     /* samples without a point because of an encoder fault */
    uint32_t serial_frames_bad;  /* serial frames dropped: CRC, COBS, runts, oversize */
    uint32_t samples_dropped;    /* stream samples lost: output queue full or stale */
    uint32_t samples_late;       /* stream samples skipped: the device fell behind */
    uint8_t joints;              /* N, 4..7 */
    aacmm_diag_joint_t joint[AACMM_JOINTS_MAX];
    uint32_t temp_faults; /* samples with AACMM_SAMPLE_TEMP_FAULT (after the joints) */
} aacmm_msg_diag_t;

typedef struct {
    int16_t status;       /* aacmm_status_t, negative */
    uint8_t request_type; /* type of the request that failed (0 if unknown) */
} aacmm_msg_error_t;

/* One decoded message. type selects the member of u. */
typedef struct {
    uint8_t type; /* aacmm_msg_type_t */
    uint8_t seq;
    union {
        aacmm_msg_ping_t ping;               /* PING_REQ, PING_RSP */
        aacmm_msg_info_t info;               /* INFO_RSP */
        aacmm_param_set_t params;            /* SET_PARAMS_REQ, GET_PARAMS_RSP */
        aacmm_msg_param_crc_t param_crc;     /* SET/SAVE_PARAMS_RSP, RESTORE_DEFAULTS_RSP */
        aacmm_msg_measure_req_t measure;     /* MEASURE_REQ */
        aacmm_sample_t sample;               /* MEASURE_RSP, SAMPLE_EVT */
        aacmm_msg_compute_req_t compute_req; /* COMPUTE_REQ */
        aacmm_msg_compute_rsp_t compute_rsp; /* COMPUTE_RSP */
        aacmm_msg_stream_t stream;           /* STREAM_START_REQ, STREAM_START_RSP */
        aacmm_msg_trigger_t trigger;         /* TRIGGER_EVT */
        aacmm_msg_diag_t diag;               /* DIAG_RSP */
        aacmm_msg_error_t error;             /* ERROR_RSP */
    } u;                                     /* empty for the other types */
} aacmm_msg_t;

/*
 * Encode *msg into out[0 .. out_cap-1] as a message body (header + payload).
 * Returns AACMM_OK and the length in *out_len (<= AACMM_PROTO_MAX_BODY), or
 * AACMM_ERR_NULL, AACMM_ERR_UNKNOWN_TYPE, AACMM_ERR_NOT_FINITE /
 * AACMM_ERR_RANGE (a field the decoder would reject), AACMM_ERR_BUFFER
 * (out_cap too small; AACMM_PROTO_MAX_BODY always suffices). On error
 * *out_len is 0 and out may hold partial output. Cost: O(body length).
 */
aacmm_status_t aacmm_msg_encode(const aacmm_msg_t *msg, uint8_t *out, size_t out_cap,
                                size_t *out_len);

/*
 * Decode body[0 .. len-1] into *msg. Reads only inside the body, writes only
 * *msg. Returns AACMM_OK or the first rule broken (see the header comment):
 * AACMM_ERR_LENGTH (shorter than the header or wrong payload size),
 * AACMM_ERR_VERSION, AACMM_ERR_UNKNOWN_TYPE, AACMM_ERR_NOT_FINITE,
 * AACMM_ERR_RANGE, AACMM_ERR_NULL. On error *msg holds type and seq if the
 * header was readable, other fields are unspecified. Cost: O(len).
 */
aacmm_status_t aacmm_msg_decode(const uint8_t *body, size_t len, aacmm_msg_t *msg);

/*
 * Encode *msg and wrap it in a serial frame (aacmm/frame.h) in out. scratch
 * (>= AACMM_PROTO_MAX_BODY bytes) holds the body meanwhile. Errors as for
 * aacmm_msg_encode and aacmm_frame_encode. Cost: O(body length).
 */
aacmm_status_t aacmm_msg_encode_frame(const aacmm_msg_t *msg, uint8_t *scratch,
                                      size_t scratch_cap, uint8_t *out, size_t out_cap,
                                      size_t *out_len);

/* Counters of rejected message bodies, by reason (caller owned; only
 * aacmm_msg_decode_counted increments them, nothing clears them). */
typedef struct {
    uint32_t ok;           /* bodies decoded */
    uint32_t length;       /* AACMM_ERR_LENGTH */
    uint32_t version;      /* AACMM_ERR_VERSION */
    uint32_t unknown_type; /* AACMM_ERR_UNKNOWN_TYPE */
    uint32_t range;        /* AACMM_ERR_RANGE */
    uint32_t not_finite;   /* AACMM_ERR_NOT_FINITE */
    uint32_t other;        /* any other status */
} aacmm_msg_stats_t;

/*
 * aacmm_msg_decode, then count the outcome in *stats (which may be NULL).
 * Same return value and cost.
 */
aacmm_status_t aacmm_msg_decode_counted(const uint8_t *body, size_t len, aacmm_msg_t *msg,
                                        aacmm_msg_stats_t *stats);

/*
 * The response type of a request type (request | 0x80), or 0 if type is not
 * a request of this version. O(1).
 */
uint8_t aacmm_msg_response_type(uint8_t request_type);

/*
 * Fill *msg with an ERROR_RSP answering a request of type request_type with
 * sequence number seq. status must be negative (AACMM_ERR_RANGE otherwise,
 * and *msg is untouched); AACMM_ERR_NULL for NULL. O(1).
 */
aacmm_status_t aacmm_msg_make_error(aacmm_msg_t *msg, uint8_t seq, uint8_t request_type,
                                    aacmm_status_t status);

/*
 * Payload length of a message body's type as its bytes define it: the
 * content byte, N, P (and for a parameter set the K_i and the thermal flag) are
 * read from payload[0 .. len-1] where the type has them, as raw values
 * (ranges are checked after the length). For a payload too short to hold
 * those fields, the length of the fields that define it (so a short payload
 * never matches). Returns 0 for unknown types (a valid empty payload also
 * gives 0: check aacmm_msg_type_known). O(1).
 */
size_t aacmm_msg_payload_len(uint8_t type, const uint8_t *payload, size_t len);

/* 1 if type is a message type of this protocol version, else 0. O(1). */
int aacmm_msg_type_known(uint8_t type);

/*
 * Encode a parameter set payload alone into out (*out_len bytes,
 * AACMM_PARAM_SET_BYTES of its N, P, S, H; at most
 * AACMM_PARAM_SET_MAX_BYTES). AACMM_ERR_NULL, AACMM_ERR_BUFFER,
 * AACMM_ERR_NOT_FINITE, AACMM_ERR_RANGE (an invalid shape, an encoder out
 * of range, enc.joints not N, a value the layout does not carry that is not
 * 0: entries past N or K_i, a beta where none is declared, t_x or t_y with
 * AACMM_TIP_Z, a cte or ref_temp without the thermal block), AACMM_ERR_RANGE
 * for a K_i above 4 or a ref_temp outside -40 .. 85 degC, or AACMM_OK.
 * O(size).
 */
aacmm_status_t aacmm_param_set_encode(const aacmm_param_set_t *set, uint8_t *out, size_t out_cap,
                                      size_t *out_len);

/* Decode and check a parameter set payload of len bytes: AACMM_ERR_LENGTH
 * (shorter than its header or not the size its header defines), then
 * AACMM_ERR_RANGE (header fields: N, tip, bits, K_i <= 4, H),
 * AACMM_ERR_NOT_FINITE, AACMM_ERR_RANGE (encoders, ref_temp outside -40 ..
 * 85 degC). Values the layout does not carry are 0. O(len). */
aacmm_status_t aacmm_param_set_decode(const uint8_t *in, size_t len, aacmm_param_set_t *set);

/*
 * The parameter-set CRC reported in device info and the *_PARAMS_RSP
 * messages: CRC-32/ISO-HDLC over the wire encoding of *set.
 * Errors as aacmm_param_set_encode (then *crc32 is 0). O(size).
 */
aacmm_status_t aacmm_param_set_crc32(const aacmm_param_set_t *set, uint32_t *crc32);

/*
 * Convert a point in mm to the wire unit (1e-4 mm), rounding to nearest and
 * clamping to the int32 range. *clipped (may be NULL) is set to 1 if the
 * value was clamped or not finite (NaN gives 0), else 0. O(1).
 */
int32_t aacmm_point_mm_to_wire(double mm, int *clipped);

#ifdef __cplusplus
}
#endif

#endif /* AACMM_PROTO_H */
