/*
 * POSIX port of the device application (aacmm-sim): the platform table on
 * Linux. Internal to the simulator.
 */
#ifndef AACMM_POSIX_PORT_H
#define AACMM_POSIX_PORT_H

#include <stddef.h>
#include <stdint.h>

#include "aacmm/device.h"
#include "aacmm_sim.h"
#include "sim_control.h"

/* Exit codes of aacmm-sim. */
#define SIM_EXIT_OK 0
#define SIM_EXIT_USAGE 2
#define SIM_EXIT_LINK 3

typedef struct {
    int serial_fd;       /* -1 if none */
    int serial_slave_fd; /* pty: our own handle on the slave side, keeps it open */
    char serial_path[256];
    int can_fd; /* -1 if none */
    int can_busy; /* the socket refused a frame: retry after a short sleep */
    const char *storage_path; /* NULL: RAM only */
    uint8_t storage[AACMM_STORE_BYTES];
    long long storage_file_bytes; /* size of the file at start-up; -1: no file */
    uint64_t t0_us; /* simulation time origin */
    aacmm_sim_t sim;
    int use_frames;           /* joints as BiSS-C/SSI frames (else counts) */
    aacmm_sim_encoders_t enc; /* the simulated encoders behind the frames */
    sim_control_t control; /* control.fd >= 0: encoders, buttons and temperatures come from it */
    /* link temperatures (AACMM_TEMP_UNIT_C; valid bit i = link i answers):
     * --temperature, default 20.00 degC on every link; has_temps 0 with
     * --no-temperature-sensors (no read_temperatures) */
    int has_temps;
    int16_t temp[AACMM_JOINTS_MAX];
    uint8_t temp_valid;
} posix_port_t;

/* The six joint readings at time t_us since the start, in counts: the one
 * place the simulated arm's joints come from. The encoder callback turns them
 * into frames (use_frames) that the device decodes. */
aacmm_status_t posix_joint_counts(posix_port_t *port, uint64_t t_us,
                                  uint32_t counts[AACMM_JOINTS_MAX]);

/* CLOCK_MONOTONIC in us. */
uint64_t posix_time_us(void);

/* Open a pseudo-terminal (path "pty") or an existing tty, raw, non-blocking.
 * Returns 0, or -1 with a one-line message in err. */
int posix_serial_open(posix_port_t *port, const char *path, char *err, size_t err_cap);

/* Open a raw SocketCAN socket on iface, non-blocking, receiving only
 * rx_id. Returns 0, or -1 with a one-line message in err. */
int posix_can_open(posix_port_t *port, const char *iface, uint32_t rx_id, char *err,
                   size_t err_cap);

/* Load the storage image from port->storage_path (missing file: blank;
 * a short file reads as erased beyond its end; port->storage_file_bytes
 * says what was there). A FILE.tmp left by a cut save is removed, with a
 * line on stderr unless quiet. Returns 0, or -1 with a message. */
int posix_storage_load(posix_port_t *port, int quiet, char *err, size_t err_cap);

/* One line for stderr: what start-up found in the storage (file size, each
 * slot, which one was loaded and why the other was not). */
void posix_storage_report(const posix_port_t *port, const aacmm_msg_diag_t *diag,
                          char *out, size_t cap);

/* Fill *pf with the port's functions (links present as opened). */
void posix_platform(posix_port_t *port, aacmm_platform_t *pf);

void posix_close(posix_port_t *port);

#endif /* AACMM_POSIX_PORT_H */
