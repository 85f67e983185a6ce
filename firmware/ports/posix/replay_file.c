/*
 * Replay files (contract: replay_file.h): the plain format and aacmm's log
 * CSV of 4 to 7 joints, every line checked before a pose is taken.
 */
#include "replay_file.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define REPLAY_LINE_MAX 4096
#define REPLAY_COLS_MAX 64
#define FLAG_ENCODER_FAULT 0x2u /* a log row without valid counts */

typedef struct {
    uint32_t *buf;
    size_t count;
    size_t cap;
    size_t joints; /* counts per pose, AACMM_JOINTS_MIN .. AACMM_JOINTS_MAX */
} pose_list_t;

/* Append one pose of l->joints counts; -1 past UINT32_MAX / joints poses or
 * when the heap says no. */
static int pose_add(pose_list_t *l, const uint32_t *pose)
{
    if (l->count == l->cap) {
        size_t ncap = l->cap == 0 ? 64 : l->cap * 2;
        uint32_t *nb;
        if (ncap > (size_t)UINT32_MAX / l->joints || ncap > SIZE_MAX / (l->joints * sizeof *nb)) {
            return -1;
        }
        nb = realloc(l->buf, ncap * l->joints * sizeof *nb);
        if (nb == NULL) {
            return -1;
        }
        l->buf = nb;
        l->cap = ncap;
    }
    memcpy(l->buf + l->count * l->joints, pose, l->joints * sizeof *pose);
    l->count++;
    return 0;
}

/* fgets stopped without a line end before the end of the file: the line is
 * longer than the buffer, or a NUL byte hides the rest of it. */
static void line_error(const char *line, size_t cap, const char *path, unsigned long lineno,
                       char *err, size_t err_cap)
{
    if (strlen(line) + 1u < cap) {
        snprintf(err, err_cap, "%s:%lu: a NUL byte (not a text file)", path, lineno);
    } else {
        snprintf(err, err_cap, "%s:%lu: line too long (more than %zu bytes)", path, lineno,
                 cap - 1u);
    }
}

/* An unsigned decimal number from s (leading blanks allowed); *end after it
 * and the blanks and line ends that follow. 0, or -1 if there is none or it
 * overflows. */
static int parse_count(const char *s, uint64_t *out, char **end)
{
    unsigned long long v;
    while (*s == ' ' || *s == '\t') {
        s++;
    }
    if (*s < '0' || *s > '9') {
        return -1;
    }
    errno = 0;
    v = strtoull(s, end, 10);
    if (errno != 0) {
        return -1;
    }
    while (**end == ' ' || **end == '\t' || **end == '\r' || **end == '\n') {
        (*end)++;
    }
    *out = v;
    return 0;
}

/* Split a CSV line (no quoting: aacmm logs have none) into fields in place;
 * returns the number of fields or -1 if more than max. */
static int csv_fields(char *line, char **fields, int max)
{
    int n = 0;
    char *p = line;
    char *nl = strpbrk(line, "\r\n");
    if (nl != NULL) {
        *nl = '\0';
    }
    for (;;) {
        char *comma = strchr(p, ',');
        if (n == max) {
            return -1;
        }
        fields[n++] = p;
        if (comma == NULL) {
            return n;
        }
        *comma = '\0';
        p = comma + 1;
    }
}

static void trim(char **s)
{
    char *e;
    while (**s == ' ' || **s == '\t') {
        (*s)++;
    }
    e = *s + strlen(*s);
    while (e > *s && (e[-1] == ' ' || e[-1] == '\t')) {
        *--e = '\0';
    }
}

/* A column name "countD..." (D decimal digits): its joint number, 1 ..
 * 999 (a longer or zero-led number reads as 999, beyond any arm), or 0 for
 * any other name. */
static int count_column(const char *name)
{
    int v = 0;
    size_t i;
    if (strncmp(name, "count", 5) != 0 || name[5] == '\0') {
        return 0;
    }
    for (i = 5; name[i] != '\0'; i++) {
        if (name[i] < '0' || name[i] > '9') {
            return 0;
        }
    }
    if (name[5] == '0' || i - 5 > 3) {
        return 999;
    }
    for (i = 5; name[i] != '\0'; i++) {
        v = v * 10 + (name[i] - '0');
    }
    return v;
}

/* A log CSV (docs/cli.md): the header names count1..countK, K = 4..7 (and
 * perhaps flags); every row gives one pose; rows flagged ENCODER_FAULT are
 * skipped. */
static int replay_csv(FILE *f, const char *path, char *header, uint64_t cpr, pose_list_t *l,
                      char *err, size_t err_cap)
{
    char line[REPLAY_LINE_MAX];
    char *fields[REPLAY_COLS_MAX];
    int col[AACMM_JOINTS_MAX];
    int flags_col = -1;
    int need = 0;
    int joints = 0;
    int n;
    int i;
    unsigned long lineno = 1;
    n = csv_fields(header, fields, REPLAY_COLS_MAX);
    if (n < 0) {
        snprintf(err, err_cap, "%s:1: more than %d columns", path, REPLAY_COLS_MAX);
        return -1;
    }
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        col[i] = -1;
    }
    for (i = 0; i < n; i++) {
        char *name = fields[i];
        int j;
        trim(&name);
        j = count_column(name);
        if (j > AACMM_JOINTS_MAX) {
            snprintf(err, err_cap,
                     "%s:1: column '%.20s': not a joint of a replay (count1..count%d, at most "
                     "%d joints)",
                     path, name, AACMM_JOINTS_MAX, AACMM_JOINTS_MAX);
            return -1;
        }
        if (j > 0) {
            if (col[j - 1] >= 0) {
                snprintf(err, err_cap, "%s:1: column count%d twice", path, j);
                return -1;
            }
            col[j - 1] = i;
            if (j > joints) {
                joints = j;
            }
        } else if (strcmp(name, "flags") == 0) {
            flags_col = i;
        }
    }
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        if (col[i] < 0 && (i < joints || i < AACMM_JOINTS_MIN)) {
            snprintf(err, err_cap,
                     "%s:1: no column count%d (a CSV replay needs count1..countK, K = %d to %d, "
                     "as in an aacmm log)",
                     path, i + 1, AACMM_JOINTS_MIN, AACMM_JOINTS_MAX);
            return -1;
        }
        if (col[i] + 1 > need) {
            need = col[i] + 1;
        }
    }
    if (flags_col + 1 > need) {
        need = flags_col + 1;
    }
    l->joints = (size_t)joints;
    while (fgets(line, sizeof line, f) != NULL) {
        uint32_t pose[AACMM_JOINTS_MAX];
        uint64_t v;
        char *end;
        lineno++;
        if (strchr(line, '\n') == NULL && !feof(f)) {
            line_error(line, sizeof line, path, lineno, err, err_cap);
            return -1;
        }
        if (line[strspn(line, " \t\r\n")] == '\0') {
            continue;
        }
        n = csv_fields(line, fields, REPLAY_COLS_MAX);
        if (n < 0) {
            snprintf(err, err_cap, "%s:%lu: more than %d columns", path, lineno, REPLAY_COLS_MAX);
            return -1;
        }
        if (n < need) {
            snprintf(err, err_cap, "%s:%lu: %d fields, the header has more", path, lineno, n);
            return -1;
        }
        if (flags_col >= 0) {
            if (parse_count(fields[flags_col], &v, &end) != 0 || *end != '\0') {
                snprintf(err, err_cap, "%s:%lu: bad flags '%.20s'", path, lineno,
                         fields[flags_col]);
                return -1;
            }
            if ((v & FLAG_ENCODER_FAULT) != 0u) {
                continue;
            }
        }
        for (i = 0; i < joints; i++) {
            if (parse_count(fields[col[i]], &v, &end) != 0 || *end != '\0') {
                snprintf(err, err_cap, "%s:%lu: count%d: expected an unsigned count, got '%.20s'",
                         path, lineno, i + 1, fields[col[i]]);
                return -1;
            }
            if (v >= cpr) {
                snprintf(err, err_cap,
                         "%s:%lu: count%d %llu is not below %llu counts per revolution", path,
                         lineno, i + 1, (unsigned long long)v, (unsigned long long)cpr);
                return -1;
            }
            pose[i] = (uint32_t)v;
        }
        if (pose_add(l, pose) != 0) {
            snprintf(err, err_cap, "%s:%lu: too many poses", path, lineno);
            return -1;
        }
    }
    return 0;
}

int replay_file_load(const char *path, uint64_t cpr, uint32_t **poses, uint32_t *n,
                     unsigned *joints, char *err, size_t err_cap)
{
    FILE *f = fopen(path, "r");
    char line[REPLAY_LINE_MAX];
    unsigned long lineno = 0;
    unsigned long first_line = 0; /* the plain format's first pose */
    pose_list_t l = {NULL, 0, 0, 0};
    if (f == NULL) {
        snprintf(err, err_cap, "cannot open replay file %s: %s", path, strerror(errno));
        return -1;
    }
    while (fgets(line, sizeof line, f) != NULL) {
        char *p = line;
        char *hash;
        uint32_t pose[AACMM_JOINTS_MAX];
        int k = 0;
        lineno++;
        if (strchr(line, '\n') == NULL && !feof(f)) {
            line_error(line, sizeof line, path, lineno, err, err_cap);
            goto fail;
        }
        if (lineno == 1 && ((line[0] >= 'a' && line[0] <= 'z') ||
                            (line[0] >= 'A' && line[0] <= 'Z'))) {
            /* A header row: a CSV with named columns (an aacmm log). */
            if (replay_csv(f, path, line, cpr, &l, err, err_cap) != 0) {
                goto fail;
            }
            break;
        }
        hash = strpbrk(line, "#\r\n");
        if (hash != NULL) {
            *hash = '\0'; /* a comment, or the line end */
        }
        for (;;) {
            char *end;
            uint64_t v;
            while (*p == ' ' || *p == '\t' || *p == ',' || *p == '\r' || *p == '\n') {
                p++;
            }
            if (*p == '\0') {
                break;
            }
            if (*p < '0' || *p > '9') {
                snprintf(err, err_cap, "%s:%lu: expected an unsigned count, got '%.20s'", path,
                         lineno, p);
                goto fail;
            }
            if (parse_count(p, &v, &end) != 0 ||
                (*end != '\0' && *end != ',' && end[-1] != ' ' && end[-1] != '\t')) {
                snprintf(err, err_cap, "%s:%lu: bad count '%.20s'", path, lineno, p);
                goto fail;
            }
            if (k == (l.joints != 0u ? (int)l.joints : AACMM_JOINTS_MAX)) {
                if (l.joints != 0u) {
                    snprintf(err, err_cap, "%s:%lu: more than %d counts, as on line %lu", path,
                             lineno, k, first_line);
                } else {
                    snprintf(err, err_cap, "%s:%lu: more than %d counts (a pose has %d to %d)",
                             path, lineno, k, AACMM_JOINTS_MIN, AACMM_JOINTS_MAX);
                }
                goto fail;
            }
            if (v >= cpr) {
                snprintf(err, err_cap, "%s:%lu: count %llu is not below %llu counts per revolution",
                         path, lineno, (unsigned long long)v, (unsigned long long)cpr);
                goto fail;
            }
            pose[k++] = (uint32_t)v;
            p = end;
        }
        if (k == 0) {
            continue; /* blank or comment line */
        }
        if (l.joints == 0u) {
            /* the first pose: every other has as many counts */
            if (k < AACMM_JOINTS_MIN) {
                snprintf(err, err_cap, "%s:%lu: %d counts (a pose has %d to %d)", path, lineno,
                         k, AACMM_JOINTS_MIN, AACMM_JOINTS_MAX);
                goto fail;
            }
            l.joints = (size_t)k;
            first_line = lineno;
        } else if ((size_t)k != l.joints) {
            snprintf(err, err_cap, "%s:%lu: %d counts, expected %d as on line %lu", path, lineno,
                     k, (int)l.joints, first_line);
            goto fail;
        }
        if (pose_add(&l, pose) != 0) {
            snprintf(err, err_cap, "%s:%lu: too many poses", path, lineno);
            goto fail;
        }
    }
    if (ferror(f)) {
        snprintf(err, err_cap, "cannot read replay file %s: %s", path, strerror(errno));
        goto fail;
    }
    fclose(f);
    if (l.count == 0) {
        snprintf(err, err_cap,
                 "%s: no poses (expected lines of %d to %d counts, or a log CSV)", path,
                 AACMM_JOINTS_MIN, AACMM_JOINTS_MAX);
        free(l.buf);
        return -1;
    }
    *poses = l.buf;
    *n = (uint32_t)l.count;
    *joints = (unsigned)l.joints;
    return 0;
fail:
    fclose(f);
    free(l.buf);
    return -1;
}
