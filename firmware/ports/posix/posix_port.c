/*
 * POSIX platform for the device application: time, serial on a pty or tty,
 * SocketCAN, parameter storage in a file, simulated encoders and button.
 */
#define _GNU_SOURCE 1

#include "posix_port.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/stat.h>

uint64_t posix_time_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

/* ---- serial ------------------------------------------------------------ */

static int make_raw(int fd)
{
    struct termios tio;
    if (tcgetattr(fd, &tio) != 0) {
        return -1;
    }
    cfmakeraw(&tio);
    tio.c_cflag |= CLOCAL | CREAD;
    tio.c_cc[VMIN] = 0;
    tio.c_cc[VTIME] = 0;
    return tcsetattr(fd, TCSANOW, &tio);
}

int posix_serial_open(posix_port_t *port, const char *path, char *err, size_t err_cap)
{
    if (strcmp(path, "pty") == 0) {
        int m = posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK);
        const char *name;
        if (m < 0) {
            snprintf(err, err_cap, "cannot open a pseudo-terminal: %s", strerror(errno));
            return -1;
        }
        if (grantpt(m) != 0 || unlockpt(m) != 0 || (name = ptsname(m)) == NULL) {
            snprintf(err, err_cap, "cannot set up the pseudo-terminal: %s", strerror(errno));
            close(m);
            return -1;
        }
        snprintf(port->serial_path, sizeof port->serial_path, "%s", name);
        /* Keep the slave open ourselves: the master then never sees a hang-up
         * when a host closes its side, and the raw settings stay. */
        port->serial_slave_fd = open(port->serial_path, O_RDWR | O_NOCTTY | O_NONBLOCK);
        if (port->serial_slave_fd < 0 || make_raw(port->serial_slave_fd) != 0) {
            snprintf(err, err_cap, "cannot configure %s: %s", port->serial_path, strerror(errno));
            close(m);
            return -1;
        }
        port->serial_fd = m;
        return 0;
    }
    port->serial_fd = open(path, O_RDWR | O_NOCTTY | O_NONBLOCK);
    if (port->serial_fd < 0) {
        snprintf(err, err_cap, "cannot open serial tty %s: %s", path, strerror(errno));
        return -1;
    }
    if (!isatty(port->serial_fd)) {
        snprintf(err, err_cap, "serial %s is not a tty", path);
        close(port->serial_fd);
        port->serial_fd = -1;
        return -1;
    }
    if (make_raw(port->serial_fd) != 0) {
        snprintf(err, err_cap, "cannot set %s to raw mode: %s", path, strerror(errno));
        close(port->serial_fd);
        port->serial_fd = -1;
        return -1;
    }
    snprintf(port->serial_path, sizeof port->serial_path, "%s", path);
    return 0;
}

static aacmm_status_t serial_read(void *ctx, uint8_t *buf, size_t cap, size_t *got)
{
    posix_port_t *p = ctx;
    ssize_t n = read(p->serial_fd, buf, cap);
    *got = 0u;
    if (n > 0) {
        *got = (size_t)n;
        return AACMM_OK;
    }
    if (n == 0 || errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) {
        return AACMM_OK;
    }
    return AACMM_ERR_IO;
}

static aacmm_status_t serial_write(void *ctx, const uint8_t *data, size_t len, size_t *accepted)
{
    posix_port_t *p = ctx;
    ssize_t n = write(p->serial_fd, data, len);
    *accepted = 0u;
    if (n >= 0) {
        *accepted = (size_t)n;
        return AACMM_OK;
    }
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) {
        return AACMM_OK;
    }
    return AACMM_ERR_IO;
}

/* ---- CAN --------------------------------------------------------------- */

int posix_can_open(posix_port_t *port, const char *iface, uint32_t rx_id, char *err,
                   size_t err_cap)
{
    struct sockaddr_can addr;
    struct can_filter filter;
    unsigned int index;
    int fd;
    if (iface[0] == '\0' || strlen(iface) >= IFNAMSIZ || strchr(iface, '/') != NULL) {
        snprintf(err, err_cap, "bad CAN interface name '%s'", iface);
        return -1;
    }
    fd = socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
    if (fd < 0) {
        int e = errno;
        if (e == EAFNOSUPPORT || e == EPROTONOSUPPORT || e == ESOCKTNOSUPPORT) {
            snprintf(err, err_cap,
                     "cannot open CAN interface %s: SocketCAN (AF_CAN) is not supported by "
                     "this kernel (%s)",
                     iface, strerror(e));
        } else {
            snprintf(err, err_cap, "cannot open a CAN socket for %s: %s", iface, strerror(e));
        }
        return -1;
    }
    index = if_nametoindex(iface);
    if (index == 0u) {
        snprintf(err, err_cap, "no CAN interface '%s' (%s)", iface, strerror(errno));
        close(fd);
        return -1;
    }
    filter.can_id = rx_id;
    filter.can_mask = CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG;
    if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, &filter, sizeof filter) != 0) {
        snprintf(err, err_cap, "cannot set the CAN filter on %s: %s", iface, strerror(errno));
        close(fd);
        return -1;
    }
    memset(&addr, 0, sizeof addr);
    addr.can_family = AF_CAN;
    addr.can_ifindex = (int)index;
    if (bind(fd, (struct sockaddr *)&addr, sizeof addr) != 0) {
        int e = errno;
        if (e == ENODEV) {
            snprintf(err, err_cap, "'%s' is not a CAN interface", iface);
        } else {
            snprintf(err, err_cap, "cannot bind to CAN interface %s: %s", iface, strerror(e));
        }
        close(fd);
        return -1;
    }
    port->can_fd = fd;
    return 0;
}

static aacmm_status_t can_send(void *ctx, const aacmm_can_frame_t *frame)
{
    posix_port_t *p = ctx;
    struct can_frame f;
    ssize_t n;
    memset(&f, 0, sizeof f);
    f.can_id = frame->id & CAN_SFF_MASK;
    f.can_dlc = frame->dlc > 8u ? 8u : frame->dlc;
    memcpy(f.data, frame->data, f.can_dlc);
    n = write(p->can_fd, &f, sizeof f);
    if (n == (ssize_t)sizeof f) {
        return AACMM_OK;
    }
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS || errno == EINTR)) {
        p->can_busy = 1;
        return AACMM_ERR_BUSY;
    }
    return AACMM_ERR_IO;
}

static aacmm_status_t can_receive(void *ctx, aacmm_can_frame_t *frame, int *got)
{
    posix_port_t *p = ctx;
    struct can_frame f;
    ssize_t n;
    *got = 0;
    for (;;) {
        n = read(p->can_fd, &f, sizeof f);
        if (n < 0) {
            if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) {
                return AACMM_OK;
            }
            return AACMM_ERR_IO;
        }
        if (n != (ssize_t)sizeof f || (f.can_id & (CAN_EFF_FLAG | CAN_RTR_FLAG | CAN_ERR_FLAG))) {
            continue; /* not a classic data frame with an 11-bit id */
        }
        frame->id = f.can_id & CAN_SFF_MASK;
        frame->dlc = f.can_dlc > 8u ? 8u : f.can_dlc;
        memset(frame->data, 0, sizeof frame->data);
        memcpy(frame->data, f.data, frame->dlc);
        *got = 1;
        return AACMM_OK;
    }
}

/* ---- storage ----------------------------------------------------------- */

/* PATH.tmp, the temporary file of a save. 0, or -1 when it does not fit. */
static int tmp_path(const char *path, char *tmp, size_t cap)
{
    int n = snprintf(tmp, cap, "%s.tmp", path);
    return (n < 0 || (size_t)n >= cap) ? -1 : 0;
}

int posix_storage_load(posix_port_t *port, int quiet, char *err, size_t err_cap)
{
    FILE *f;
    size_t n;
    char tmp[PATH_MAX];
    struct stat st;
    memset(port->storage, 0xFF, sizeof port->storage);
    port->storage_file_bytes = -1;
    if (port->storage_path == NULL) {
        return 0;
    }
    if (tmp_path(port->storage_path, tmp, sizeof tmp) != 0) {
        snprintf(err, err_cap, "storage file name too long: %s", port->storage_path);
        return -1;
    }
    /* A save that was cut leaves its temporary file: never reuse it. */
    if (lstat(tmp, &st) == 0) {
        if (unlink(tmp) != 0) {
            snprintf(err, err_cap, "cannot remove the stale %s: %s", tmp, strerror(errno));
            return -1;
        }
        if (!quiet) {
            fprintf(stderr, "aacmm-sim: storage %s: removed the stale %s (a save was cut)\n",
                    port->storage_path, tmp);
        }
    }
    f = fopen(port->storage_path, "rb");
    if (f == NULL) {
        if (errno == ENOENT) {
            return 0; /* blank storage; created on the first save */
        }
        snprintf(err, err_cap, "cannot read storage file %s: %s", port->storage_path,
                 strerror(errno));
        return -1;
    }
    if (fstat(fileno(f), &st) != 0 || !S_ISREG(st.st_mode)) {
        snprintf(err, err_cap, "storage file %s is not a regular file", port->storage_path);
        fclose(f);
        return -1;
    }
    port->storage_file_bytes = (long long)st.st_size;
    n = fread(port->storage, 1, sizeof port->storage, f);
    if (ferror(f)) {
        snprintf(err, err_cap, "cannot read storage file %s: %s", port->storage_path,
                 strerror(errno));
        fclose(f);
        return -1;
    }
    (void)n; /* a short file reads as erased beyond its end */
    fclose(f);
    return 0;
}

static const char *slot_text(uint8_t state)
{
    switch (state) {
    case AACMM_SLOT_ERASED: return "erased";
    case AACMM_SLOT_NEWEST: return "newest record";
    case AACMM_SLOT_OLDER: return "older record, the fallback";
    case AACMM_SLOT_BAD_CRC: return "rejected: CRC mismatch (a cut save or damage)";
    case AACMM_SLOT_BAD_CONTENTS:
        return "rejected: parameters this device cannot use (out of range, or a thermal block "
               "without temperature sensors)";
    case AACMM_SLOT_VERSION: return "rejected: record of another format version";
    case AACMM_SLOT_BAD_LENGTH: return "rejected: wrong payload length";
    case AACMM_SLOT_INCOMPLETE: return "rejected: incomplete record (a save cut after it began)";
    case AACMM_SLOT_UNRECOGNISED: return "rejected: not a record (unrecognised data)";
    default: return "unreadable";
    }
}

void posix_storage_report(const posix_port_t *port, const aacmm_msg_diag_t *diag,
                          char *out, size_t cap)
{
    size_t len = 0;
    int newest = -1;
    int k;
#define ADD(...)                                                                                   \
    do {                                                                                           \
        if (len < cap) {                                                                           \
            int w_ = snprintf(out + len, cap - len, __VA_ARGS__);                                  \
            len += w_ > 0 ? (size_t)w_ : 0u;                                                       \
        }                                                                                          \
    } while (0)
    if (cap == 0u) {
        return;
    }
    out[0] = '\0';
    if (port->storage_path == NULL) {
        ADD("storage: none given (--storage FILE): a saved set lives in RAM until exit");
        return;
    }
    ADD("storage %s: ", port->storage_path);
    if (port->storage_file_bytes < 0) {
        ADD("no file yet (the first save creates it); running on defaults");
        return;
    }
    if (port->storage_file_bytes != (long long)AACMM_STORE_BYTES) {
        ADD("%lld bytes, expected %u (%s); ", port->storage_file_bytes, AACMM_STORE_BYTES,
            port->storage_file_bytes < (long long)AACMM_STORE_BYTES
                ? "the rest reads as erased"
                : "the rest is ignored");
    }
    for (k = 0; k < 2; k++) {
        if (diag->slot_state[k] == AACMM_SLOT_NEWEST) {
            newest = k;
        }
    }
    if (newest >= 0) {
        int other = 1 - newest;
        uint8_t os = diag->slot_state[other];
        ADD("loaded slot %d (generation %lu); slot %d: %s", newest,
            (unsigned long)diag->slot_generation[newest], other, slot_text(os));
        if (os == AACMM_SLOT_OLDER || os == AACMM_SLOT_BAD_CRC ||
            os == AACMM_SLOT_BAD_CONTENTS || os == AACMM_SLOT_BAD_LENGTH) {
            uint32_t d = diag->slot_generation[other] - diag->slot_generation[newest];
            ADD(" (generation %lu)", (unsigned long)diag->slot_generation[other]);
            if (os != AACMM_SLOT_OLDER && d != 0u && d < 0x80000000u) {
                ADD(": it was newer, so the set in use may be older than the last save");
            }
        }
        return;
    }
    for (k = 0; k < 2; k++) {
        ADD("slot %d: %s; ", k, slot_text(diag->slot_state[k]));
    }
    ADD("no valid record, running on defaults");
#undef ADD
}

static aacmm_status_t storage_read(void *ctx, uint32_t offset, uint8_t *buf, size_t len)
{
    posix_port_t *p = ctx;
    if ((uint64_t)offset + len > sizeof p->storage) {
        return AACMM_ERR_IO;
    }
    memcpy(buf, p->storage + offset, len);
    return AACMM_OK;
}

/* fsync the directory holding path, so a rename in it is durable. */
static int sync_dir_of(const char *path)
{
    char dir[PATH_MAX];
    const char *slash = strrchr(path, '/');
    int fd;
    int rc;
    if (slash == NULL) {
        snprintf(dir, sizeof dir, ".");
    } else if (slash == path) {
        snprintf(dir, sizeof dir, "/");
    } else if ((size_t)(slash - path) < sizeof dir) {
        memcpy(dir, path, (size_t)(slash - path));
        dir[slash - path] = '\0';
    } else {
        return -1;
    }
    fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) {
        return -1;
    }
    rc = fsync(fd);
    close(fd);
    return rc;
}

/* Create PATH.tmp afresh: never follow a link planted there, never write
 * into a file someone else opened. One stale or planted entry is removed
 * (the link itself, not its target) and creation retried once. */
static int open_tmp(const char *path, const char *tmp)
{
    int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (fd < 0 && errno == EEXIST) {
        fprintf(stderr, "aacmm-sim: storage %s: removed %s found in the way of a save\n", path,
                tmp);
        if (unlink(tmp) != 0) {
            return -1;
        }
        fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
    }
    return fd;
}

/* Write the whole image to a fresh PATH.tmp, fsync it, rename it over PATH,
 * fsync the directory: the file is always either the old or the new image,
 * and the new one survives a power cut once the save has answered. */
static int storage_commit(const posix_port_t *p)
{
    char tmp[PATH_MAX];
    const uint8_t *b = p->storage;
    size_t left = sizeof p->storage;
    int fd;
    if (tmp_path(p->storage_path, tmp, sizeof tmp) != 0) {
        return -1;
    }
    fd = open_tmp(p->storage_path, tmp);
    if (fd < 0) {
        return -1;
    }
    while (left > 0u) {
        ssize_t n = write(fd, b, left);
        if (n < 0) {
            if (errno == EINTR) {
                continue;
            }
            close(fd);
            unlink(tmp);
            return -1;
        }
        b += n;
        left -= (size_t)n;
    }
    if (fsync(fd) != 0 || close(fd) != 0) {
        unlink(tmp);
        return -1;
    }
    if (rename(tmp, p->storage_path) != 0) {
        unlink(tmp);
        return -1;
    }
    return sync_dir_of(p->storage_path);
}

static aacmm_status_t storage_write(void *ctx, uint32_t offset, const uint8_t *data, size_t len)
{
    posix_port_t *p = ctx;
    uint8_t old[AACMM_STORE_BYTES];
    if ((uint64_t)offset + len > sizeof p->storage) {
        return AACMM_ERR_IO;
    }
    if (p->storage_path == NULL) {
        memcpy(p->storage + offset, data, len);
        return AACMM_OK;
    }
    memcpy(old, p->storage, sizeof old);
    memcpy(p->storage + offset, data, len);
    if (storage_commit(p) != 0) {
        fprintf(stderr, "aacmm-sim: cannot write storage file %s: %s\n", p->storage_path,
                strerror(errno));
        memcpy(p->storage, old, sizeof old);
        return AACMM_ERR_IO;
    }
    return AACMM_OK;
}

/* ---- encoders, button, table ------------------------------------------ */

static uint64_t time_us(void *ctx)
{
    (void)ctx;
    return posix_time_us();
}

aacmm_status_t posix_joint_counts(posix_port_t *port, uint64_t t_us,
                                  uint32_t counts[AACMM_JOINTS_MAX])
{
    if (port->control.fd >= 0) {
        memcpy(counts, port->control.counts, sizeof port->control.counts);
        return AACMM_OK;
    }
    return aacmm_sim_read(&port->sim, t_us, counts);
}

static aacmm_status_t read_encoders(void *ctx, uint32_t counts[AACMM_JOINTS_MAX])
{
    posix_port_t *p = ctx;
    return posix_joint_counts(p, posix_time_us() - p->t0_us, counts);
}

/* The encoder interfaces: each joint's count goes out as a frame, clock by
 * clock, from the simulated encoder (with the corruption asked for). */
static aacmm_status_t read_encoder_frames(void *ctx, aacmm_enc_frame_t frames[AACMM_JOINTS_MAX])
{
    posix_port_t *p = ctx;
    uint32_t counts[AACMM_JOINTS_MAX];
    if (posix_joint_counts(p, posix_time_us() - p->t0_us, counts) != AACMM_OK ||
        aacmm_sim_encoders_frames(&p->enc, counts, frames) != AACMM_OK) {
        return AACMM_ERR_IO;
    }
    return AACMM_OK;
}

static aacmm_status_t read_buttons(void *ctx, uint8_t *pressed)
{
    posix_port_t *p = ctx;
    if (p->control.fd >= 0) {
        *pressed = p->control.buttons;
        return AACMM_OK;
    }
    *pressed = aacmm_sim_button(&p->sim, posix_time_us() - p->t0_us);
    return AACMM_OK;
}

/* The link temperatures: the control channel's (`temps`) when it is open,
 * else the fixed ones of --temperature. Never blocks. */
static aacmm_status_t read_temperatures(void *ctx, int16_t temp[AACMM_JOINTS_MAX], uint8_t *valid)
{
    posix_port_t *p = ctx;
    if (p->control.fd >= 0) {
        memcpy(temp, p->control.temp, sizeof p->control.temp);
        *valid = p->control.temp_valid;
    } else {
        memcpy(temp, p->temp, sizeof p->temp);
        *valid = p->temp_valid;
    }
    return AACMM_OK;
}

void posix_platform(posix_port_t *port, aacmm_platform_t *pf)
{
    memset(pf, 0, sizeof *pf);
    pf->ctx = port;
    pf->time_us = time_us;
    if (port->serial_fd >= 0) {
        pf->serial_read = serial_read;
        pf->serial_write = serial_write;
    }
    if (port->can_fd >= 0) {
        pf->can_send = can_send;
        pf->can_receive = can_receive;
    }
    pf->read_encoders = read_encoders;
    if (port->use_frames) {
        pf->read_encoder_frames = read_encoder_frames;
    }
    pf->read_buttons = read_buttons;
    if (port->has_temps) {
        pf->read_temperatures = read_temperatures;
    }
    pf->storage_read = storage_read;
    pf->storage_write = storage_write;
    pf->storage_bytes = AACMM_STORE_BYTES;
    pf->storage_kind = (uint8_t)(port->storage_path != NULL ? AACMM_STORAGE_KIND_FILE
                                                            : AACMM_STORAGE_KIND_RAM);
    pf->storage_flags = (uint8_t)(port->storage_path != NULL ? AACMM_STORAGE_PERSISTENT : 0u);
}

void posix_close(posix_port_t *port)
{
    if (port->serial_fd >= 0) {
        if (port->serial_slave_fd < 0) {
            (void)tcdrain(port->serial_fd);
        }
        close(port->serial_fd);
        port->serial_fd = -1;
    }
    if (port->serial_slave_fd >= 0) {
        close(port->serial_slave_fd);
        port->serial_slave_fd = -1;
    }
    if (port->can_fd >= 0) {
        close(port->can_fd);
        port->can_fd = -1;
    }
}
