/*
 * The simulator's control channel (docs/simulator.md, "Control channel"):
 * a host program drives the encoders and the buttons of aacmm-sim over an
 * inherited stream socket or pipe pair, and hears back when the device's
 * streams start and stop. Internal to the POSIX port.
 *
 * Host -> simulator, one ASCII command per line ('\n'; '\r' ignored):
 *
 *     counts C1 C2 C3 C4 C5 C6   the encoders read these counts from now on
 *                                (each < the simulated counts per revolution)
 *     buttons MASK               button levels, bit i = button i held (0..3)
 *     temps T1 .. Tn             the link temperatures the sensors read from
 *                                now on (degC, up to 2 decimals, -327.67 ..
 *                                327.67; '-': that link's sensor does not
 *                                answer); n = 6 or 7 as for counts (6: link 7
 *                                has no reading), or one value for every link
 *     sync TOKEN                 answered with "sync TOKEN" (TOKEN: 1..64
 *                                printable characters without spaces)
 *
 * Barriers: `buttons` and `sync` end a batch. The lines after them are
 * applied only after the device has run one complete poll, so a button edge
 * is always reported with the counts set before it, and "sync TOKEN" means
 * that every earlier command has been seen by the device.
 *
 * Simulator -> host, one line each:
 *
 *     control 1                          once, when the channel opens (version)
 *     stream serial|can on RATE CONTENT  the host (re)started a stream
 *     stream serial|can off              the stream stopped
 *     sync TOKEN                         see above
 *     error TEXT                         a command line was refused (and ignored)
 *
 * End of file on the channel ends the simulator like SIGTERM: an operator
 * that dies takes its simulated arm with it.
 */
#ifndef AACMM_SIM_CONTROL_H
#define AACMM_SIM_CONTROL_H

#include <stddef.h>
#include <stdint.h>

#include "aacmm/device.h"

#define SIM_CONTROL_LINE_MAX 256u   /* longest command line, '\n' included */
#define SIM_CONTROL_OUT_BYTES 8192u /* events waiting for the host to read */

typedef struct {
    int fd;                 /* -1: no control channel */
    uint64_t cpr;           /* counts must be below this */
    uint32_t counts[AACMM_JOINTS_MAX]; /* a 7th joint only for 7-joint arm models */
    uint8_t buttons;
    int temps;              /* the simulator has temperature sensors: `temps` is taken */
    int16_t temp[AACMM_JOINTS_MAX]; /* AACMM_TEMP_UNIT_C */
    uint8_t temp_valid;     /* bit i: link i's sensor answers */
    /* input: bytes received, not yet applied */
    char in[2u * SIM_CONTROL_LINE_MAX];
    size_t in_len;
    int discarding;         /* inside an overlong line: drop to its end */
    int barrier;            /* a batch ended: wait for a device poll */
    int eof;                /* the host closed the channel */
    /* sync tokens to answer after the next poll */
    char pending[8][72];
    unsigned npending;
    /* output */
    char out[SIM_CONTROL_OUT_BYTES];
    size_t out_len;
    uint32_t out_dropped;   /* event bytes dropped: the host did not read */
    /* stream state last reported, per link */
    uint32_t starts[AACMM_LINKS];
    uint8_t active[AACMM_LINKS];
} sim_control_t;

/* Take over inherited descriptor `spec` (a decimal fd number) as the control
 * channel: checked open, made non-blocking and close-on-exec, "control 1"
 * queued. Returns 0, or -1 with a one-line message in err. */
int sim_control_open(sim_control_t *c, const char *spec, uint64_t cpr, char *err, size_t err_cap);

/* A temperature "[-+]D[.D[D]]" in degC (1 to 3 integer digits, up to 2
 * decimals) as AACMM_TEMP_UNIT_C in *out, exactly. 0, or -1 for anything
 * else or a value outside lo .. hi (0.01 degC). */
int sim_parse_temp_c(const char *s, int32_t lo, int32_t hi, int16_t *out);

/* Read what the host sent and apply commands up to the next barrier. Call
 * when the descriptor is readable, and again after each device poll while
 * sim_control_has_work() says so. */
void sim_control_input(sim_control_t *c);

/* After a device poll: answer the pending syncs, report stream changes,
 * lift the barrier. */
void sim_control_after_poll(sim_control_t *c, const aacmm_device_t *dev);

/* 1 while commands wait behind a barrier (the port must poll the device
 * again at once). */
int sim_control_has_work(const sim_control_t *c);

/* Write queued output as far as the descriptor takes it. */
void sim_control_flush(sim_control_t *c);

void sim_control_close(sim_control_t *c);

#endif /* AACMM_SIM_CONTROL_H */
