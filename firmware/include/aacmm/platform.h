/*
 * aacmm platform table: everything board-specific the device application
 * (aacmm/device.h) needs, as a small table of functions plus a user context.
 *
 * A port (the POSIX simulator, an ARM board) fills one aacmm_platform_t and
 * passes it to aacmm_device_init; the device copies the table and calls the
 * functions only from aacmm_device_init and aacmm_device_poll, on the caller's
 * thread. Every function receives the table's ctx as its first argument.
 *
 * Rules for every function:
 *   - it never blocks: it does what it can right now and returns;
 *   - it returns an aacmm_status_t (AACMM_OK, or AACMM_ERR_IO for a hardware
 *     or OS failure; the device counts failures, it never stops for them);
 *   - it never allocates and never keeps pointers to the device's buffers
 *     beyond the call.
 *
 * Optional groups: set both functions of a group to NULL when the board does
 * not have it. Serial (serial_read + serial_write) and CAN (can_send +
 * can_receive) are the two links; at least one must be present. Without a
 * button function the device emits no trigger events. Without storage (or with
 * storage_bytes < AACMM_STORE_BYTES) the device runs on its defaults and
 * answers SAVE_PARAMS with AACMM_ERR_UNSUPPORTED.
 */
#ifndef AACMM_PLATFORM_H
#define AACMM_PLATFORM_H

#include <stddef.h>
#include <stdint.h>

#include "aacmm/encoder_frame.h"
#include "aacmm/kinematics.h"
#include "aacmm/proto.h"
#include "aacmm/proto_can.h"
#include "aacmm/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
    void *ctx; /* user context, passed to every function; may be NULL */

    /* Monotonic time in microseconds since an arbitrary origin; never goes
     * backwards, does not wrap within the device's lifetime (2^64 us).
     * Required. */
    uint64_t (*time_us)(void *ctx);

    /* Serial link. serial_read copies up to cap (> 0) received bytes into buf
     * and sets *got (0 when nothing is waiting). serial_write takes up to len
     * (> 0) bytes from data and sets *accepted (0 .. len; fewer than len when
     * the driver's buffer is full: the device keeps the rest and retries). */
    aacmm_status_t (*serial_read)(void *ctx, uint8_t *buf, size_t cap, size_t *got);
    aacmm_status_t (*serial_write)(void *ctx, const uint8_t *data, size_t len, size_t *accepted);

    /* CAN link (classic CAN, 11-bit ids). can_send queues one frame for
     * transmission: AACMM_OK when taken, AACMM_ERR_BUSY when the driver's
     * queue is full (the device keeps the frame and retries, in order).
     * can_receive fills *frame and sets *got = 1 if a frame was waiting, else
     * *got = 0. */
    aacmm_status_t (*can_send)(void *ctx, const aacmm_can_frame_t *frame);
    aacmm_status_t (*can_receive)(void *ctx, aacmm_can_frame_t *frame, int *got);

    /* The joints, one of two ways (at least one is required; frames win when
     * both are set):
     * The device reads AACMM_JOINTS_MAX (7) joints and uses the first N of
     * its arm model; a port with fewer encoders fills the rest (count 0,
     * or a frame of count 0).
     * read_encoders: the raw readings as counts (a port that decodes
     * its encoders itself, or quadrature counters). A reading at or above the
     * joint's counts per revolution is a fault of that joint.
     * read_encoder_frames: the frames as the port's encoder interfaces
     * sampled them (aacmm/encoder_frame.h; one frame per joint, n_bits 0 for
     * a joint that did not answer), decoded by the device with the joint
     * configuration of aacmm_device_config_t.encoders: BiSS-C CRC, error and
     * warning bits, SSI framing, stuck lines and timeouts are checked there.
     * Either way a failed call (AACMM_ERR_IO) is a READ fault of every joint,
     * and a sample with a faulty joint has no point (ENCODER_FAULT). */
    aacmm_status_t (*read_encoders)(void *ctx, uint32_t counts[AACMM_JOINTS_MAX]);
    aacmm_status_t (*read_encoder_frames)(void *ctx, aacmm_enc_frame_t frames[AACMM_JOINTS_MAX]);

    /* The buttons' levels: bit i of *pressed is 1 while button i is held
     * (bit AACMM_BUTTON_CAPTURE = 0: the probe button that takes a point; bit
     * AACMM_BUTTON_UNDO = 1: the second button; aacmm/proto.h). A board with
     * one button reports bit 0 only; bits from AACMM_BUTTONS up are ignored.
     * Optional. */
    aacmm_status_t (*read_buttons)(void *ctx, uint8_t *pressed);

    /* Link temperatures (issue 27). Optional: NULL means the device has no
     * temperature sensors (INFO without AACMM_BUILD_TEMPERATURES; the
     * TEMPERATURES content and a parameter set with the thermal block are
     * refused with AACMM_ERR_UNSUPPORTED). read_temperatures fills temp[i]
     * (links i = 0 .. AACMM_JOINTS_MAX - 1, in AACMM_TEMP_UNIT_C = 0.01 degC)
     * and sets bit i of *valid when link i's sensor gave a reading (a board
     * with one sensor copies it to every link). It never blocks: it returns
     * the latest completed conversion, and a sensor with no conversion for
     * longer than the port's own timeout is not valid. AACMM_ERR_IO: no
     * reading at all (every link not valid). The device reads it once per
     * sample; a link of the arm without a valid reading in
     * AACMM_REF_TEMP_MIN .. AACMM_REF_TEMP_MAX flags the sample
     * (AACMM_SAMPLE_TEMP_FAULT) and, with the thermal block in force, leaves
     * it without a point. */
    aacmm_status_t (*read_temperatures)(void *ctx, int16_t temp[AACMM_JOINTS_MAX], uint8_t *valid);

    /* Non-volatile storage of storage_bytes bytes addressed from 0 (an EEPROM
     * or a flash sector pair behind the port). A read of never-written bytes
     * may return anything (erased flash reads 0xFF). A write may be cut by a
     * power failure after any byte; the device's double-buffered record
     * format (device.h) survives that. Optional.
     * storage_erase (optional, for flash): set [offset, offset + len) to the
     * erased state before a write; the device calls it with one whole record
     * slot (AACMM_STORE_SLOT_BYTES at a multiple of it), so a port with flash
     * pages puts each slot in a page of its own. It may be cut too.
     * storage_kind (AACMM_STORAGE_KIND_*) and storage_flags
     * (AACMM_STORAGE_PERSISTENT) say what the store is; the device reports
     * them in its diagnostics so the host can warn about a store that does
     * not survive power-off. */
    aacmm_status_t (*storage_read)(void *ctx, uint32_t offset, uint8_t *buf, size_t len);
    aacmm_status_t (*storage_write)(void *ctx, uint32_t offset, const uint8_t *data, size_t len);
    aacmm_status_t (*storage_erase)(void *ctx, uint32_t offset, size_t len);
    uint32_t storage_bytes;
    uint8_t storage_kind;
    uint8_t storage_flags;
} aacmm_platform_t;

#ifdef __cplusplus
}
#endif

#endif /* AACMM_PLATFORM_H */
