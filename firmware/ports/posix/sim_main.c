/*
 * aacmm-sim: the device application as a POSIX process (docs/simulator.md).
 *
 * Serial on a pseudo-terminal or a tty, CAN on a SocketCAN interface, the
 * simulated arm as encoder source, parameter storage in a file. The main loop
 * sleeps in ppoll() until link activity or the device's next deadline, so it
 * neither busy-waits nor oversleeps a 1 kHz stream.
 */
#define _GNU_SOURCE 1

#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <time.h>
#include <unistd.h>

#include "aacmm/device.h"
#include "aacmm_sim.h"
#include "posix_port.h"
#include "replay_file.h"

#define SERIAL_TXQ_BYTES (256u * 1024u)

static volatile sig_atomic_t stop_signal = 0;
static posix_port_t port;
static aacmm_device_t dev;
static uint8_t serial_txq[SERIAL_TXQ_BYTES];

static void on_signal(int sig)
{
    stop_signal = sig;
}

static void usage(FILE *f)
{
    fputs("usage: aacmm-sim [--serial pty|PATH] [--can IFACE] [--node N] [--storage FILE]\n"
          "                 [--motion sweep|walk|static|replay:FILE] [--seed N]\n"
          "                 [--noise-counts N] [--encoder-bits B | --cpr N]\n"
          "                 [--encoder biss|ssi|ssi-gray|counts] [--encoder-faults N]\n"
          "                 [--button-every SECONDS] [--control FD] [--serial-number N]\n"
          "                 [--param-set FILE] [--joint-limits LO:HI,..|-,..]\n"
          "                 [--temperature C[,C..] | --no-temperature-sensors] [--quiet]\n"
          "At least one of --serial and --can. Link temperature sensors read 20.00 degC\n"
          "unless --temperature (degC, -40..85, one value or one per joint) says otherwise.\n"
          "See docs/simulator.md.\n",
          f);
}

static int usage_error(const char *fmt, const char *arg)
{
    fputs("aacmm-sim: ", stderr);
    fprintf(stderr, fmt, arg);
    fputc('\n', stderr);
    usage(stderr);
    return SIM_EXIT_USAGE;
}

/* Parse an unsigned decimal integer in lo..hi. */
static int parse_u64(const char *s, uint64_t lo, uint64_t hi, uint64_t *out)
{
    char *end;
    unsigned long long v;
    if (s == NULL || *s < '0' || *s > '9') {
        return -1;
    }
    errno = 0;
    v = strtoull(s, &end, 10);
    if (errno != 0 || *end != '\0' || v < lo || v > hi) {
        return -1;
    }
    *out = v;
    return 0;
}

typedef struct {
    const char *serial;
    const char *can;
    uint64_t node;
    const char *storage;
    const char *param_set; /* built-in defaults: a parameter set's wire bytes */
    aacmm_sim_motion_t motion;
    const char *replay_path;
    uint64_t seed;
    uint64_t noise;
    uint64_t cpr;
    int have_bits;
    int have_cpr;
    uint64_t button_us;
    const char *control;
    int have_motion;
    uint64_t serial_number;
    int have_limits; /* --joint-limits: the motion inside an arm model's ranges */
    aacmm_sim_ranges_t ranges;
    uint8_t encoder; /* AACMM_ENC_* */
    uint64_t encoder_faults;
    int no_temps;          /* --no-temperature-sensors */
    int ntemps;            /* --temperature values: 0 (default 20.00 degC), 1, 6 or 7 */
    int16_t temp[AACMM_JOINTS_MAX];
    int quiet;
} options_t;

/* Read a parameter set in its wire encoding (docs/protocol.md 2.3) from
 * path into *set, checked as SET_PARAMS checks it. 0, or -1 with err. */
static int load_param_set(const char *path, int sensors, aacmm_param_set_t *set, char *err,
                          size_t err_cap)
{
    uint8_t buf[AACMM_PARAM_SET_MAX_BYTES + 1u];
    size_t n;
    aacmm_status_t st;
    aacmm_param_set_t p;
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        snprintf(err, err_cap, "--param-set %s: %s", path, strerror(errno));
        return -1;
    }
    n = fread(buf, 1u, sizeof buf, f);
    fclose(f);
    st = n > AACMM_PARAM_SET_MAX_BYTES ? AACMM_ERR_LENGTH : aacmm_param_set_decode(buf, n, &p);
    if (st == AACMM_OK) {
        st = aacmm_arm_validate_f64(&p.arm);
    }
    if (st == AACMM_OK && p.err.thermal != 0u && !sensors) {
        snprintf(err, err_cap,
                 "--param-set %s: has the thermal block, which needs the link temperature "
                 "sensors (not with --no-temperature-sensors)",
                 path);
        return -1;
    }
    if (st != AACMM_OK) {
        snprintf(err, err_cap, "--param-set %s: not a parameter set this device takes (%s)", path,
                 aacmm_status_str(st));
        return -1;
    }
    *set = p;
    return 0;
}

/* --joint-limits: 1 to AACMM_JOINTS_MAX comma-separated items, each LO:HI in
 * degrees (LO < HI, within +-720, a span under 360) or '-' (no limit, a roll);
 * joints past the list have none. 0, or -1 for a malformed list. */
static int parse_joint_limits(const char *v, options_t *o)
{
    const char *p = v;
    int j = 0;
    for (;;) {
        if (j >= AACMM_JOINTS_MAX) {
            return -1;
        }
        if (p[0] == '-' && (p[1] == ',' || p[1] == '\0')) {
            o->ranges.limited[j] = 0u;
            p += 1;
        } else {
            char *end;
            double lo;
            double hi;
            errno = 0;
            lo = strtod(p, &end);
            if (errno != 0 || end == p || *end != ':') {
                return -1;
            }
            p = end + 1;
            hi = strtod(p, &end);
            if (errno != 0 || end == p || (*end != ',' && *end != '\0')) {
                return -1;
            }
            if (!(lo >= -720.0 && hi <= 720.0 && lo < hi && hi - lo < 360.0)) {
                return -1;
            }
            o->ranges.limited[j] = 1u;
            o->ranges.lo_rad[j] = (float)(lo * 0.017453292519943295);
            o->ranges.hi_rad[j] = (float)(hi * 0.017453292519943295);
            p = end;
        }
        j++;
        if (*p == '\0') {
            return 0;
        }
        p++; /* the comma */
        if (*p == '\0') {
            return -1;
        }
    }
}

/* --temperature: 1, 6 or 7 comma-separated degC values, each -40 .. 85 with
 * up to 2 decimals. 0, or -1 for a malformed list. */
static int parse_temperatures(const char *v, options_t *o)
{
    char buf[128];
    char *p;
    int n = 0;
    if (strlen(v) >= sizeof buf) {
        return -1;
    }
    memcpy(buf, v, strlen(v) + 1u);
    p = buf;
    for (;;) {
        char *comma = strchr(p, ',');
        if (comma != NULL) {
            *comma = '\0';
        }
        if (n >= AACMM_JOINTS_MAX ||
            sim_parse_temp_c(p, AACMM_REF_TEMP_MIN, AACMM_REF_TEMP_MAX, &o->temp[n]) != 0) {
            return -1;
        }
        n++;
        if (comma == NULL) {
            break;
        }
        p = comma + 1;
    }
    if (n != 1 && n != AACMM_JOINTS && n != AACMM_JOINTS_MAX) {
        return -1;
    }
    o->ntemps = n;
    return 0;
}

static int parse_args(int argc, char **argv, options_t *o)
{
    int i;
    memset(o, 0, sizeof *o);
    o->node = 1u;
    o->motion = AACMM_SIM_WALK;
    o->cpr = UINT64_C(1) << 32;
    o->serial_number = 1u;
    o->encoder = (uint8_t)AACMM_ENC_BISS_C;
    for (i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = NULL;
        char name[32];
        const char *eq = strchr(a, '=');
        size_t nlen = eq != NULL ? (size_t)(eq - a) : strlen(a);
        if (strncmp(a, "--", 2) != 0 || nlen >= sizeof name) {
            return usage_error("unexpected argument '%s'", a);
        }
        memcpy(name, a, nlen);
        name[nlen] = '\0';
        if (strcmp(name, "--no-temperature-sensors") == 0) {
            if (eq != NULL) {
                return usage_error("%s takes no value", name);
            }
            o->no_temps = 1;
            continue;
        }
        if (strcmp(name, "--quiet") == 0 || strcmp(name, "--help") == 0) {
            if (eq != NULL) {
                return usage_error("%s takes no value", name);
            }
            if (strcmp(name, "--help") == 0) {
                usage(stdout);
                exit(SIM_EXIT_OK);
            }
            o->quiet = 1;
            continue;
        }
        if (eq != NULL) {
            v = eq + 1;
        } else if (i + 1 < argc) {
            v = argv[++i];
        }
        if (v == NULL || v[0] == '\0') {
            return usage_error("%s needs a value", name);
        }
        if (strcmp(name, "--serial") == 0) {
            o->serial = v;
        } else if (strcmp(name, "--can") == 0) {
            o->can = v;
        } else if (strcmp(name, "--node") == 0) {
            if (parse_u64(v, 0u, AACMM_CAN_NODE_ID_MAX, &o->node) != 0) {
                return usage_error("--node: '%s' is not a CAN node id 0..15", v);
            }
        } else if (strcmp(name, "--storage") == 0) {
            o->storage = v;
        } else if (strcmp(name, "--param-set") == 0) {
            o->param_set = v;
        } else if (strcmp(name, "--motion") == 0) {
            if (strcmp(v, "sweep") == 0) {
                o->motion = AACMM_SIM_SWEEP;
            } else if (strcmp(v, "walk") == 0) {
                o->motion = AACMM_SIM_WALK;
            } else if (strcmp(v, "static") == 0) {
                o->motion = AACMM_SIM_STATIC;
            } else if (strncmp(v, "replay:", 7) == 0 && v[7] != '\0') {
                o->motion = AACMM_SIM_REPLAY;
                o->replay_path = v + 7;
            } else {
                return usage_error("--motion: '%s' is not sweep, walk, static or replay:FILE", v);
            }
            o->have_motion = 1;
        } else if (strcmp(name, "--seed") == 0) {
            if (parse_u64(v, 0u, UINT32_MAX, &o->seed) != 0) {
                return usage_error("--seed: '%s' is not a number 0..4294967295", v);
            }
        } else if (strcmp(name, "--noise-counts") == 0) {
            if (parse_u64(v, 0u, AACMM_SIM_NOISE_MAX, &o->noise) != 0) {
                return usage_error("--noise-counts: '%s' is not a number 0..1073741824", v);
            }
        } else if (strcmp(name, "--encoder-bits") == 0) {
            uint64_t b;
            if (parse_u64(v, 1u, 32u, &b) != 0) {
                return usage_error("--encoder-bits: '%s' is not 1..32", v);
            }
            o->cpr = UINT64_C(1) << b;
            o->have_bits = 1;
        } else if (strcmp(name, "--cpr") == 0) {
            if (parse_u64(v, 2u, UINT64_C(1) << 32, &o->cpr) != 0) {
                return usage_error("--cpr: '%s' is not 2..4294967296", v);
            }
            o->have_cpr = 1;
        } else if (strcmp(name, "--button-every") == 0) {
            char *end;
            double s;
            errno = 0;
            s = strtod(v, &end);
            if (errno != 0 || end == v || *end != '\0' || !(s >= 0.001 && s <= 86400.0)) {
                return usage_error("--button-every: '%s' is not a time 0.001..86400 s", v);
            }
            o->button_us = (uint64_t)(s * 1e6 + 0.5);
        } else if (strcmp(name, "--encoder") == 0) {
            if (strcmp(v, "biss") == 0) {
                o->encoder = (uint8_t)AACMM_ENC_BISS_C;
            } else if (strcmp(v, "ssi") == 0) {
                o->encoder = (uint8_t)AACMM_ENC_SSI_BINARY;
            } else if (strcmp(v, "ssi-gray") == 0) {
                o->encoder = (uint8_t)AACMM_ENC_SSI_GRAY;
            } else if (strcmp(v, "counts") == 0) {
                o->encoder = (uint8_t)AACMM_ENC_COUNTS;
            } else {
                return usage_error("--encoder: '%s' is not biss, ssi, ssi-gray or counts", v);
            }
        } else if (strcmp(name, "--encoder-faults") == 0) {
            if (parse_u64(v, 0u, UINT32_MAX, &o->encoder_faults) != 0) {
                return usage_error("--encoder-faults: '%s' is not a number 0..4294967295", v);
            }
        } else if (strcmp(name, "--joint-limits") == 0) {
            if (parse_joint_limits(v, o) != 0) {
                return usage_error("--joint-limits: '%s' is not 1..7 comma-separated LO:HI "
                                   "(deg, LO < HI, within +-720, a span under 360) or '-'",
                                   v);
            }
            o->have_limits = 1;
        } else if (strcmp(name, "--temperature") == 0) {
            if (parse_temperatures(v, o) != 0) {
                return usage_error("--temperature: '%s' is not 1, 6 or 7 comma-separated "
                                   "temperatures in degC (-40..85, up to 2 decimals)",
                                   v);
            }
        } else if (strcmp(name, "--control") == 0) {
            o->control = v;
        } else if (strcmp(name, "--serial-number") == 0) {
            if (parse_u64(v, 0u, UINT32_MAX, &o->serial_number) != 0) {
                return usage_error("--serial-number: '%s' is not a number 0..4294967295", v);
            }
        } else {
            return usage_error("unknown option '%s'", name);
        }
    }
    if (o->have_bits && o->have_cpr) {
        return usage_error("%s", "--encoder-bits and --cpr are mutually exclusive");
    }
    if (o->have_limits && (o->control != NULL || o->motion == AACMM_SIM_REPLAY)) {
        return usage_error("%s", "--joint-limits shapes the simulator's own motion: not with "
                                 "--control or --motion replay:FILE");
    }
    if (o->control != NULL && (o->have_motion || o->noise != 0u || o->button_us != 0u)) {
        return usage_error("%s", "--control drives the encoders and buttons: no --motion, "
                                 "--noise-counts or --button-every with it");
    }
    if (o->no_temps && o->ntemps != 0) {
        return usage_error("%s", "--temperature and --no-temperature-sensors are mutually "
                                 "exclusive");
    }
    if (o->serial == NULL && o->can == NULL) {
        return usage_error("%s", "at least one of --serial and --can is required");
    }
    if (o->encoder == AACMM_ENC_COUNTS && o->encoder_faults != 0u) {
        return usage_error("%s", "--encoder-faults needs frames (--encoder biss, ssi or ssi-gray)");
    }
    return SIM_EXIT_OK;
}

static void print_counters(void)
{
    const aacmm_device_counters_t *c = aacmm_device_counters(&dev);
    const aacmm_deframer_stats_t *d = aacmm_device_serial_stats(&dev);
    fprintf(stderr,
            "aacmm-sim: stopped: requests %u, errors %u, samples sent %u, dropped %u (stale %u), "
            "late %u, "
            "events %u (dropped %u), serial frames ok %u, crc errors %u, cobs errors %u, "
            "storage errors %u, bad records %u, io errors %u/%u, temperature faults %u\n",
            c->requests, c->error_responses, c->samples_sent, c->samples_dropped, c->samples_stale,
            c->samples_late,
            c->events_sent, c->events_dropped, d->frames_ok, d->crc_errors, d->cobs_errors,
            c->storage_errors, c->storage_bad_records, c->serial_io_errors, c->can_io_errors,
            c->temp_faults);
}

int main(int argc, char **argv)
{
    options_t o;
    char err[512];
    int rc;
    uint32_t *replay = NULL;
    uint32_t replay_n = 0;
    unsigned replay_joints = 0;
    aacmm_sim_config_t sc;
    aacmm_param_set_t defaults;
    aacmm_device_config_t dc;
    aacmm_platform_t pf;
    aacmm_status_t st;
    sigset_t block;
    sigset_t waitmask;
    struct sigaction sa;
    int i;

    setvbuf(stdout, NULL, _IOLBF, 0);
    rc = parse_args(argc, argv, &o);
    if (rc != SIM_EXIT_OK) {
        return rc;
    }

    memset(&port, 0, sizeof port);
    port.serial_fd = -1;
    port.serial_slave_fd = -1;
    port.can_fd = -1;
    port.storage_path = o.storage;

    /* Signals: blocked except while sleeping in ppoll, so none is lost. */
    sigemptyset(&block);
    sigaddset(&block, SIGINT);
    sigaddset(&block, SIGTERM);
    sigaddset(&block, SIGHUP);
    sigprocmask(SIG_BLOCK, &block, &waitmask);
    sigdelset(&waitmask, SIGINT);
    sigdelset(&waitmask, SIGTERM);
    sigdelset(&waitmask, SIGHUP);
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGHUP, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);
    (void)prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL); /* wake on time for 1 kHz */

    /* Encoder source. */
    if (o.motion == AACMM_SIM_REPLAY &&
        replay_file_load(o.replay_path, o.cpr, &replay, &replay_n, &replay_joints, err,
                         sizeof err) != 0) {
        fprintf(stderr, "aacmm-sim: %s\n", err);
        return SIM_EXIT_USAGE;
    }
    memset(&sc, 0, sizeof sc);
    sc.motion = o.motion;
    sc.seed = (uint32_t)o.seed;
    sc.noise_counts = (uint32_t)o.noise;
    sc.counts_per_rev = o.cpr;
    sc.replay = replay;
    sc.replay_poses = replay_n;
    sc.replay_joints = (uint8_t)replay_joints;
    sc.button_period_us = o.button_us;
    if (o.have_limits) {
        sc.ranges = &o.ranges; /* o lives as long as main */
    }
    if (aacmm_sim_init(&port.sim, &sc) != AACMM_OK) {
        fprintf(stderr, "aacmm-sim: bad simulation settings\n");
        return SIM_EXIT_USAGE;
    }
    if (o.encoder != AACMM_ENC_COUNTS) {
        aacmm_sim_encoders_config_t ec;
        memset(&ec, 0, sizeof ec);
        for (i = 0; i < AACMM_JOINTS_MAX; i++) {
            ec.joint[i].interface = o.encoder;
            ec.joint[i].bits = aacmm_sim_bits_for_cpr(o.cpr);
        }
        ec.fault_every = (uint32_t)o.encoder_faults;
        ec.seed = (uint32_t)o.seed;
        if (aacmm_sim_encoders_init(&port.enc, &ec) != AACMM_OK) {
            fprintf(stderr, "aacmm-sim: bad encoder settings\n");
            return SIM_EXIT_USAGE;
        }
        port.use_frames = 1;
    }

    if (posix_storage_load(&port, o.quiet, err, sizeof err) != 0) {
        fprintf(stderr, "aacmm-sim: %s\n", err);
        return SIM_EXIT_USAGE;
    }
    /* Link temperatures: 20.00 degC on every link, or --temperature's. */
    port.has_temps = !o.no_temps;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        port.temp[i] = o.ntemps == 0   ? (int16_t)2000
                       : o.ntemps == 1 ? o.temp[0]
                       : i < o.ntemps  ? o.temp[i]
                                       : AACMM_TEMP_NONE;
    }
    port.temp_valid = (uint8_t)(o.ntemps == AACMM_JOINTS ? 0x3Fu : 0x7Fu);
    port.control.fd = -1;
    if (o.control != NULL && sim_control_open(&port.control, o.control, o.cpr, err, sizeof err) != 0) {
        fprintf(stderr, "aacmm-sim: %s\n", err);
        return SIM_EXIT_USAGE;
    }
    /* the control channel's `temps` starts from them */
    port.control.temps = port.has_temps;
    memcpy(port.control.temp, port.temp, sizeof port.temp);
    port.control.temp_valid = port.temp_valid;

    /* Links. */
    if (o.serial != NULL && posix_serial_open(&port, o.serial, err, sizeof err) != 0) {
        fprintf(stderr, "aacmm-sim: %s\n", err);
        posix_close(&port);
        return SIM_EXIT_LINK;
    }
    if (o.can != NULL &&
        posix_can_open(&port, o.can, AACMM_CAN_ID_ISOTP_REQUEST + (uint32_t)o.node, err,
                       sizeof err) != 0) {
        fprintf(stderr, "aacmm-sim: %s\n", err);
        posix_close(&port);
        return SIM_EXIT_LINK;
    }

    /* The device: its defaults are the paper's arm with the simulated
     * encoders, or the parameter set given. */
    (void)aacmm_param_set_default(&defaults);
    for (i = 0; i < AACMM_JOINTS; i++) {
        defaults.enc.counts_per_rev[i] = o.cpr;
    }
    if (o.param_set != NULL &&
        load_param_set(o.param_set, port.has_temps, &defaults, err, sizeof err) != 0) {
        fprintf(stderr, "aacmm-sim: %s\n", err);
        posix_close(&port);
        return SIM_EXIT_USAGE;
    }
    memset(&dc, 0, sizeof dc);
    dc.serial_number = (uint32_t)o.serial_number;
    dc.can_node_id = (uint8_t)o.node;
    dc.defaults = &defaults;
    dc.serial_txq = serial_txq;
    dc.serial_txq_bytes = sizeof serial_txq;
    dc.max_catch_up = 1000u; /* a loaded host may deschedule us for a while: up to 1 s at 1 kHz */
    dc.reset_cause = (uint8_t)AACMM_RESET_POWER_ON; /* a process start is a power-up */
    dc.boot_count = 1u;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        dc.encoders[i] = port.enc.cfg.joint[i];
    }
    /* a replay gives K joints: a set of another N would read invented or
     * dropped joints, so the device refuses it (checked at start below) */
    dc.joints_exact = o.motion == AACMM_SIM_REPLAY ? (uint8_t)replay_joints : 0u;
    port.t0_us = posix_time_us();
    posix_platform(&port, &pf);
    st = aacmm_device_init(&dev, &dc, &pf);
    if (st != AACMM_OK) {
        fprintf(stderr, "aacmm-sim: device set-up failed: %s\n", aacmm_status_str(st));
        posix_close(&port);
        return SIM_EXIT_USAGE;
    }
    if (o.ntemps > 1) {
        /* one temperature per link: as many as the arm the device starts with */
        aacmm_msg_info_t info;
        (void)aacmm_device_info(&dev, &info);
        if ((unsigned)o.ntemps != (unsigned)info.joints) {
            fprintf(stderr, "aacmm-sim: --temperature gives %d temperatures, the arm has %u "
                            "links\n",
                    o.ntemps, (unsigned)info.joints);
            posix_close(&port);
            free(replay);
            return SIM_EXIT_USAGE;
        }
    }
    if (o.motion == AACMM_SIM_REPLAY) {
        /* The replay gives joints 1..K: the arm the device starts with (its
         * stored set, else --param-set's, else the paper's 6) must have K. */
        aacmm_msg_info_t info;
        (void)aacmm_device_info(&dev, &info);
        if (info.joints != replay_joints) {
            fprintf(stderr, "aacmm-sim: replay file %s has %u joints, the arm %u\n",
                    o.replay_path, replay_joints, (unsigned)info.joints);
            posix_close(&port);
            free(replay);
            return SIM_EXIT_USAGE;
        }
    }
    if (!o.quiet) {
        aacmm_msg_diag_t diag;
        char line[1024];
        (void)aacmm_device_diag(&dev, &diag);
        posix_storage_report(&port, &diag, line, sizeof line);
        fprintf(stderr, "aacmm-sim: %s\n", line);
    }

    if (port.serial_fd >= 0) {
        printf("aacmm-sim: serial %s\n", port.serial_path);
        fflush(stdout);
    }
    if (port.can_fd >= 0) {
        printf("aacmm-sim: can %s node %lu\n", o.can, (unsigned long)o.node);
        fflush(stdout);
    }
    printf("aacmm-sim: ready\n");
    fflush(stdout);

    while (!stop_signal) {
        struct pollfd fds[3];
        nfds_t nfds = 0;
        uint64_t now;
        uint64_t deadline;
        uint64_t wait_us;
        struct timespec ts;
        sim_control_input(&port.control);
        if (port.control.eof) {
            break; /* the controlling program went away: end as on SIGTERM */
        }
        aacmm_device_poll(&dev);
        sim_control_after_poll(&port.control, &dev);
        if (stop_signal) {
            break;
        }
        port.can_busy = 0;
        deadline = aacmm_device_next_deadline_us(&dev);
        {
            /* Wake at the simulated button's next edge, so short presses are seen. */
            uint64_t t = posix_time_us() - port.t0_us;
            uint64_t edge = aacmm_sim_next_button_edge_us(&port.sim, t);
            if (edge != UINT64_MAX && port.t0_us + edge < deadline) {
                deadline = port.t0_us + edge;
            }
        }
        if (port.serial_fd >= 0) {
            fds[nfds].fd = port.serial_fd;
            /* Input only when the device will read it: a request that waits
             * for the line must not wake us in a busy loop. */
            fds[nfds].events = aacmm_device_serial_wants_input(&dev) ? POLLIN : 0;
            if (aacmm_device_serial_pending(&dev) > 0u) {
                fds[nfds].events |= POLLOUT;
            }
            fds[nfds].revents = 0;
            nfds++;
        }
        if (port.can_fd >= 0) {
            fds[nfds].fd = port.can_fd;
            fds[nfds].events = POLLIN;
            fds[nfds].revents = 0;
            nfds++;
            /* Frames waiting for the socket: look again in 1 ms (POLLOUT
             * does not report ENOBUFS relief). */
            if (aacmm_device_can_pending(&dev) > 0u) {
                uint64_t soon = posix_time_us() + 1000u;
                if (soon < deadline) {
                    deadline = soon;
                }
            }
        }
        if (port.control.fd >= 0) {
            fds[nfds].fd = port.control.fd;
            fds[nfds].events = port.control.barrier ? 0 : POLLIN;
            if (port.control.out_len > 0u) {
                fds[nfds].events |= POLLOUT;
            }
            fds[nfds].revents = 0;
            nfds++;
            if (sim_control_has_work(&port.control)) {
                deadline = 0u; /* commands wait behind a barrier: poll again now */
            }
        }
        now = posix_time_us();
        wait_us = deadline > now ? deadline - now : 0u;
        ts.tv_sec = (time_t)(wait_us / 1000000u);
        ts.tv_nsec = (long)((wait_us % 1000000u) * 1000u);
        if (ppoll(fds, nfds, &ts, &waitmask) < 0 && errno != EINTR) {
            fprintf(stderr, "aacmm-sim: poll failed: %s\n", strerror(errno));
            break;
        }
        {
            /* ppoll returning ready descriptors leaves a signal pending
             * (the mask is restored first): look for one. */
            sigset_t pend;
            if (sigpending(&pend) == 0 &&
                (sigismember(&pend, SIGINT) == 1 || sigismember(&pend, SIGTERM) == 1 ||
                 sigismember(&pend, SIGHUP) == 1)) {
                stop_signal = 1;
            }
        }
        for (i = 0; i < (int)nfds; i++) {
            if (fds[i].fd == port.control.fd && (fds[i].revents & POLLOUT) != 0) {
                sim_control_flush(&port.control);
            }
            if (fds[i].fd == port.serial_fd &&
                (fds[i].revents & (POLLERR | POLLHUP | POLLNVAL)) != 0) {
                /* A tty that hung up or went away (USB unplugged): no spinning. */
                struct timespec nap = {0, 10000000L};
                nanosleep(&nap, NULL);
            }
        }
    }

    /* Clean shutdown: give queued output a moment to drain, then close. */
    {
        uint64_t until = posix_time_us() + 200000u;
        aacmm_device_flush(&dev);
        while (aacmm_device_serial_pending(&dev) > 0u && posix_time_us() < until) {
            struct pollfd pfd;
            pfd.fd = port.serial_fd;
            pfd.events = POLLOUT;
            pfd.revents = 0;
            if (poll(&pfd, 1, 20) <= 0) {
                break; /* nobody reads: give up */
            }
            aacmm_device_flush(&dev);
        }
    }
    if (!o.quiet) {
        print_counters();
    }
    posix_close(&port);
    sim_control_close(&port.control);
    free(replay);
    return SIM_EXIT_OK;
}
