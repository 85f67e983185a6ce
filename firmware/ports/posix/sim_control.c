/*
 * The simulator's control channel: see sim_control.h and docs/simulator.md.
 */
#define _GNU_SOURCE 1

#include "sim_control.h"

#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static void emit(sim_control_t *c, const char *fmt, ...)
{
    char line[160];
    va_list ap;
    int n;
    va_start(ap, fmt);
    n = vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    if (n < 0) {
        return;
    }
    if ((size_t)n >= sizeof line - 1u) {
        n = (int)(sizeof line - 2u);
    }
    line[n++] = '\n';
    if ((size_t)n > sizeof c->out - c->out_len) {
        c->out_dropped += (uint32_t)n;
        return;
    }
    memcpy(c->out + c->out_len, line, (size_t)n);
    c->out_len += (size_t)n;
}

int sim_control_open(sim_control_t *c, const char *spec, uint64_t cpr, char *err, size_t err_cap)
{
    char *end;
    long fd;
    int fl;
    memset(c, 0, sizeof *c);
    c->fd = -1;
    c->cpr = cpr;
    errno = 0;
    fd = strtol(spec, &end, 10);
    if (spec[0] < '0' || spec[0] > '9' || *end != '\0' || errno != 0 || fd < 0 || fd > 65535) {
        snprintf(err, err_cap, "--control: '%s' is not a file descriptor number", spec);
        return -1;
    }
    fl = fcntl((int)fd, F_GETFL);
    if (fl < 0) {
        snprintf(err, err_cap, "--control: descriptor %ld is not open: %s", fd, strerror(errno));
        return -1;
    }
    if ((fl & O_ACCMODE) != O_RDWR) {
        snprintf(err, err_cap, "--control: descriptor %ld is not open for reading and writing",
                 fd);
        return -1;
    }
    if (fcntl((int)fd, F_SETFL, fl | O_NONBLOCK) != 0 ||
        fcntl((int)fd, F_SETFD, FD_CLOEXEC) != 0) {
        snprintf(err, err_cap, "--control: cannot set up descriptor %ld: %s", fd,
                 strerror(errno));
        return -1;
    }
    c->fd = (int)fd;
    emit(c, "control 1");
    return 0;
}

static int parse_u64(const char *s, uint64_t *out)
{
    char *end;
    unsigned long long v;
    if (*s < '0' || *s > '9') {
        return -1;
    }
    errno = 0;
    v = strtoull(s, &end, 10);
    if (errno != 0 || *end != '\0') {
        return -1;
    }
    *out = v;
    return 0;
}

int sim_parse_temp_c(const char *s, int32_t lo, int32_t hi, int16_t *out)
{
    int32_t v = 0;
    int neg = 0;
    int digits = 0;
    int dec = 0;
    if (*s == '-' || *s == '+') {
        neg = *s == '-';
        s++;
    }
    while (*s >= '0' && *s <= '9') {
        if (++digits > 3) {
            return -1;
        }
        v = v * 10 + (*s++ - '0');
    }
    if (digits == 0) {
        return -1;
    }
    v *= 100;
    if (*s == '.') {
        s++;
        while (*s >= '0' && *s <= '9') {
            if (++dec > 2) {
                return -1;
            }
            v += (*s++ - '0') * (dec == 1 ? 10 : 1);
        }
        if (dec == 0) {
            return -1;
        }
    }
    if (*s != '\0') {
        return -1;
    }
    if (neg) {
        v = -v;
    }
    if (v < lo || v > hi) {
        return -1;
    }
    *out = (int16_t)v;
    return 0;
}

/* Split line into at most max blank-separated words; returns the count, or
 * max + 1 if there are more. */
static int split(char *line, char **words, int max)
{
    int n = 0;
    char *p = line;
    for (;;) {
        while (*p == ' ' || *p == '\t') {
            p++;
        }
        if (*p == '\0') {
            return n;
        }
        if (n == max) {
            return max + 1;
        }
        words[n++] = p;
        while (*p != '\0' && *p != ' ' && *p != '\t') {
            p++;
        }
        if (*p != '\0') {
            *p++ = '\0';
        }
    }
}

/* Apply one command line (NUL-terminated, no '\n'). */
static void command(sim_control_t *c, char *line)
{
    char *w[9];
    int n = split(line, w, 8);
    int i;
    uint64_t v;
    if (n == 0) {
        return;
    }
    if (strcmp(w[0], "counts") == 0) {
        uint32_t counts[AACMM_JOINTS_MAX] = {0u};
        if (n != 1 + AACMM_JOINTS && n != 1 + AACMM_JOINTS_MAX) {
            emit(c, "error counts needs %d or %d values", AACMM_JOINTS, AACMM_JOINTS_MAX);
            return;
        }
        for (i = 0; i < n - 1; i++) {
            if (parse_u64(w[1 + i], &v) != 0 || v >= c->cpr) {
                emit(c, "error counts: '%.24s' is not a count below %llu", w[1 + i],
                     (unsigned long long)c->cpr);
                return;
            }
            counts[i] = (uint32_t)v;
        }
        memcpy(c->counts, counts, sizeof counts);
    } else if (strcmp(w[0], "temps") == 0) {
        int16_t t[AACMM_JOINTS_MAX] = {0};
        uint8_t valid = 0u;
        if (!c->temps) {
            emit(c, "error temps: the simulator has no temperature sensors");
            return;
        }
        if (n != 2 && n != 1 + AACMM_JOINTS && n != 1 + AACMM_JOINTS_MAX) {
            emit(c, "error temps needs 1, %d or %d values", AACMM_JOINTS, AACMM_JOINTS_MAX);
            return;
        }
        for (i = 0; i < n - 1; i++) {
            if (strcmp(w[1 + i], "-") == 0) {
                t[i] = AACMM_TEMP_NONE;
                continue;
            }
            if (sim_parse_temp_c(w[1 + i], -32767, 32767, &t[i]) != 0) {
                emit(c, "error temps: '%.24s' is not a temperature in degC (-327.67 .. 327.67, "
                        "up to 2 decimals) or '-'",
                     w[1 + i]);
                return;
            }
            valid = (uint8_t)(valid | (1u << i));
        }
        if (n == 2) { /* one value for every link */
            for (i = 1; i < AACMM_JOINTS_MAX; i++) {
                t[i] = t[0];
            }
            valid = (valid & 1u) != 0u ? 0x7Fu : 0u;
        } else {
            for (i = n - 1; i < AACMM_JOINTS_MAX; i++) {
                t[i] = AACMM_TEMP_NONE;
            }
        }
        memcpy(c->temp, t, sizeof t);
        c->temp_valid = valid;
    } else if (strcmp(w[0], "buttons") == 0) {
        if (n != 2 || parse_u64(w[1], &v) != 0 || v > 3u) {
            emit(c, "error buttons needs a mask 0..3");
            return;
        }
        c->buttons = (uint8_t)v;
        c->barrier = 1;
    } else if (strcmp(w[0], "sync") == 0) {
        size_t len;
        if (n != 2 || (len = strlen(w[1])) == 0u || len >= sizeof c->pending[0]) {
            emit(c, "error sync needs one token of 1..%u characters",
                 (unsigned)(sizeof c->pending[0] - 1u));
            return;
        }
        for (i = 0; w[1][i] != '\0'; i++) {
            if (w[1][i] < '!' || w[1][i] > '~') {
                emit(c, "error sync token must be printable ASCII");
                return;
            }
        }
        memcpy(c->pending[c->npending], w[1], len + 1u);
        c->npending++;
        c->barrier = 1;
    } else {
        emit(c, "error unknown command '%.32s'", w[0]);
    }
}

/* Apply complete lines from the buffer until a barrier or the buffer ends. */
static void apply(sim_control_t *c)
{
    size_t start = 0;
    while (!c->barrier && c->npending < sizeof c->pending / sizeof c->pending[0]) {
        char *nl = memchr(c->in + start, '\n', c->in_len - start);
        size_t len;
        if (nl == NULL) {
            break;
        }
        len = (size_t)(nl - (c->in + start));
        *nl = '\0';
        if (c->discarding) {
            c->discarding = 0; /* the end of an overlong line */
        } else {
            char *line = c->in + start;
            if (len > 0u && line[len - 1u] == '\r') {
                line[len - 1u] = '\0';
            }
            command(c, line);
        }
        start += len + 1u;
    }
    memmove(c->in, c->in + start, c->in_len - start);
    c->in_len -= start;
    if (c->in_len >= SIM_CONTROL_LINE_MAX && memchr(c->in, '\n', c->in_len) == NULL) {
        emit(c, "error line longer than %u bytes", SIM_CONTROL_LINE_MAX - 1u);
        c->in_len = 0u;
        c->discarding = 1;
    }
}

void sim_control_input(sim_control_t *c)
{
    if (c->fd < 0) {
        return;
    }
    apply(c);
    while (!c->barrier && !c->eof && c->in_len < sizeof c->in) {
        ssize_t n = read(c->fd, c->in + c->in_len, sizeof c->in - c->in_len);
        if (n == 0) {
            c->eof = 1;
            break;
        }
        if (n < 0) {
            if (errno == EINTR) {
                continue;
            }
            if (errno != EAGAIN && errno != EWOULDBLOCK) {
                c->eof = 1; /* a broken channel ends the run as EOF does */
            }
            break;
        }
        c->in_len += (size_t)n;
        apply(c);
    }
}

static void report_stream(sim_control_t *c, const aacmm_device_t *dev, unsigned link,
                          const char *name)
{
    aacmm_device_stream_info_t s;
    if (aacmm_device_stream_info(dev, link, &s) != AACMM_OK) {
        return;
    }
    if (s.starts != c->starts[link]) {
        c->starts[link] = s.starts;
        /* started (perhaps stopped again within the same poll) */
        emit(c, "stream %s on %u %u", name, (unsigned)s.rate_hz, (unsigned)s.content);
        c->active[link] = 1u;
    }
    if (c->active[link] && !s.active) {
        emit(c, "stream %s off", name);
        c->active[link] = 0u;
    }
}

void sim_control_after_poll(sim_control_t *c, const aacmm_device_t *dev)
{
    unsigned i;
    if (c->fd < 0) {
        return;
    }
    report_stream(c, dev, AACMM_LINK_SERIAL, "serial");
    report_stream(c, dev, AACMM_LINK_CAN, "can");
    for (i = 0; i < c->npending; i++) {
        emit(c, "sync %s", c->pending[i]);
    }
    c->npending = 0;
    c->barrier = 0;
    sim_control_flush(c);
}

int sim_control_has_work(const sim_control_t *c)
{
    if (c->fd < 0) {
        return 0;
    }
    return (c->barrier || c->npending > 0u || memchr(c->in, '\n', c->in_len) != NULL) ? 1 : 0;
}

void sim_control_flush(sim_control_t *c)
{
    while (c->fd >= 0 && c->out_len > 0u) {
        ssize_t n = write(c->fd, c->out, c->out_len);
        if (n < 0) {
            if (errno == EINTR) {
                continue;
            }
            if (errno != EAGAIN && errno != EWOULDBLOCK) {
                c->out_dropped += (uint32_t)c->out_len; /* nobody listens any more */
                c->out_len = 0u;
            }
            return;
        }
        memmove(c->out, c->out + n, c->out_len - (size_t)n);
        c->out_len -= (size_t)n;
    }
}

void sim_control_close(sim_control_t *c)
{
    if (c->fd >= 0) {
        close(c->fd);
        c->fd = -1;
    }
}
