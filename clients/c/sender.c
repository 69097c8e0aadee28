/* streamseg-send: stream a joint-positions CSV to a streamseg daemon (protocol v1).
 *
 *   streamseg-send TAKE.csv [--to tcp://127.0.0.1:5560] [--stream ID] [--fps HZ]
 *                  [--batch N] [--speed X] [--units mm] [--up y] [--keys DIR]
 *
 * The CSV is the one `streamseg segment` reads: a header naming each coordinate
 * <joint>_x, <joint>_y, <joint>_z (CMU/Acclaim, HDM05, BVH or Kinect joint names) and
 * optionally a `time` column in seconds (`time_ms` in milliseconds) whose median step gives
 * the frame rate when --fps does not. An empty cell or `nan` is a marker dropout, sent as NaN
 * (the daemon's gap filler handles it). Messages (docs/protocol.md): two ZeroMQ frames, the
 * topic "<type>/<stream>/" and a msgpack map; one `announce` (joint names, parents all -1),
 * `frames` packets of --batch frames (float64 little-endian, shape (n, n_joints, 3), `seq` =
 * the stream index of the first frame), one `end`. --speed 1 (default) paces the packets in
 * real time, 0 sends as fast as the daemon takes them (PUSH waits when its queue is full).
 * --keys DIR: CURVE with the keys `streamseg keys DIR` wrote (keys.h).
 *
 * C99 with POSIX (getline, clock_gettime, nanosleep), libzmq and msgpack-c.
 * Exit codes: 0 sent, 1 a ZeroMQ failure, 2 bad arguments or an unreadable CSV.
 */
#define _POSIX_C_SOURCE 200809L

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>

#include "keys.h"

#include <msgpack.h>
#include <zmq.h>

typedef struct {
    char **joints;      /* joint names, in order of first appearance */
    int n_joints;
    double *values;     /* n_rows * n_joints * 3 */
    size_t n_rows;
    double fps;         /* from the time column, 0 without one */
} Take;

static void die(int code, const char *fmt, const char *a, const char *b) {
    fprintf(stderr, fmt, a, b);
    fputc('\n', stderr);
    exit(code);
}

static void *grow(void *p, size_t n) {
    void *q = realloc(p, n ? n : 1);
    if (!q) die(1, "%s%s", "out of memory", "");
    return q;
}

/* Split `line` in place at commas; returns the number of fields (pointers in *out). */
static int split(char *line, char ***out, int *cap) {
    int n = 0;
    char *s = line;
    for (;;) {
        if (n == *cap) {
            *cap = *cap ? 2 * *cap : 64;
            *out = grow(*out, (size_t)*cap * sizeof(char *));
        }
        (*out)[n++] = s;
        char *c = strchr(s, ',');
        if (!c) break;
        *c = '\0';
        s = c + 1;
    }
    char *last = (*out)[n - 1];  /* the line's end: no newline in the last field */
    last[strcspn(last, "\r\n")] = '\0';
    return n;
}

static char *trim(char *s) {
    while (isspace((unsigned char)*s) || *s == '"') s++;
    size_t n = strlen(s);
    while (n && (isspace((unsigned char)s[n - 1]) || s[n - 1] == '"')) s[--n] = '\0';
    return s;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static Take read_csv(const char *path) {
    Take t = {0};
    FILE *f = fopen(path, "r");
    if (!f) die(2, "%s: %s", path, strerror(errno));
    char *line = NULL, **fields = NULL;
    size_t len = 0;
    int cap = 0;
    if (getline(&line, &len, f) < 0) die(2, "%s: %s", path, "empty file, expected a header");
    int n_fields = split(line, &fields, &cap);
    int time_col = -1;
    double time_scale = 1.0;
    int *col = grow(NULL, (size_t)n_fields * 3 * sizeof(int)); /* joint j axis a -> column */
    for (int i = 0; i < n_fields * 3; i++) col[i] = -1;
    t.joints = grow(NULL, (size_t)n_fields * sizeof(char *));
    for (int i = 0; i < n_fields; i++) {
        char *name = trim(fields[i]);
        size_t n = strlen(name);
        if (time_col < 0 && (!strcasecmp(name, "time") || !strcasecmp(name, "timestamp") ||
                             !strcasecmp(name, "t") || !strcasecmp(name, "time_s"))) {
            time_col = i;
        } else if (time_col < 0 && (!strcasecmp(name, "time_ms") ||
                                    !strcasecmp(name, "timestamp_ms"))) {
            time_col = i;
            time_scale = 1e-3;
        } else if (n > 2 && strchr("_.- :", name[n - 2]) &&
                   strchr("xyz", tolower((unsigned char)name[n - 1]))) {
            int axis = tolower((unsigned char)name[n - 1]) - 'x';
            name[n - 2] = '\0';
            int j = 0;
            while (j < t.n_joints && strcmp(t.joints[j], name)) j++;
            if (j == t.n_joints) {
                t.joints[j] = grow(NULL, n - 1);
                memcpy(t.joints[j], name, n - 1);
                t.n_joints++;
            }
            col[3 * j + axis] = i;
        }
    }
    if (!t.n_joints) die(2, "%s: %s", path, "no column is named <joint>_x / _y / _z");
    for (int i = 0; i < 3 * t.n_joints; i++)
        if (col[i] < 0) die(2, "%s: joint %s needs an _x, an _y and a _z column", path,
                            t.joints[i / 3]);
    size_t cap_rows = 0, n_times = 0;
    double *times = NULL;
    size_t lineno = 1;
    while (getline(&line, &len, f) >= 0) {
        lineno++;
        if (line[strspn(line, " \t\r\n")] == '\0') continue;
        int n = split(line, &fields, &cap);
        if (n < n_fields) {
            char where[32];
            snprintf(where, sizeof where, "%zu", lineno);
            die(2, "%s:%s: fewer cells than the header names", path, where);
        }
        if (t.n_rows == cap_rows) {
            cap_rows = cap_rows ? 2 * cap_rows : 1024;
            t.values = grow(t.values, cap_rows * 3 * (size_t)t.n_joints * sizeof(double));
            times = grow(times, cap_rows * sizeof(double));
        }
        double *row = t.values + t.n_rows * 3 * (size_t)t.n_joints;
        for (int i = 0; i < 3 * t.n_joints; i++) {
            char *cell = trim(fields[col[i]]), *end;
            row[i] = *cell ? strtod(cell, &end) : NAN;
            if (*cell && *end) {
                char where[32];
                snprintf(where, sizeof where, "%zu", lineno);
                die(2, "%s:%s: a cell that is not a number", path, where);
            }
        }
        if (time_col >= 0) times[n_times++] = strtod(fields[time_col], NULL) * time_scale;
        t.n_rows++;
    }
    if (!t.n_rows) die(2, "%s: %s", path, "no frames after the header");
    /* the median positive step, rounded as streamseg's reader rounds it */
    size_t n_steps = 0;
    for (size_t i = 1; i < n_times; i++)
        if (times[i] > times[i - 1]) times[n_steps++] = times[i] - times[i - 1];
    if (n_steps) {
        qsort(times, n_steps, sizeof(double), cmp_double);
        double median = n_steps % 2 ? times[n_steps / 2]
                                    : 0.5 * (times[n_steps / 2 - 1] + times[n_steps / 2]);
        t.fps = round(1e6 / median) / 1e6;
    }
    free(times);
    free(col);
    free(fields);
    free(line);
    fclose(f);
    return t;
}

static void pack_str(msgpack_packer *pk, const char *s) {
    size_t n = strlen(s);
    msgpack_pack_str(pk, n);
    msgpack_pack_str_body(pk, s, n);
}

/* The common head of every message body: v, type, stream (and `extra` more pairs). */
static void pack_head(msgpack_packer *pk, const char *type, const char *stream, int extra) {
    msgpack_pack_map(pk, 3 + extra);
    pack_str(pk, "v");
    msgpack_pack_int(pk, 1);
    pack_str(pk, "type");
    pack_str(pk, type);
    pack_str(pk, "stream");
    pack_str(pk, stream);
}

static void send_message(void *sock, const char *type, const char *stream,
                         const msgpack_sbuffer *body) {
    char topic[160];
    int n = snprintf(topic, sizeof topic, "%s/%s/", type, stream);
    if (zmq_send(sock, topic, (size_t)n, ZMQ_SNDMORE) < 0 ||
        zmq_send(sock, body->data, body->size, 0) < 0)
        die(1, "send: %s%s", zmq_strerror(zmq_errno()), "");
}

static double now(clockid_t clock) {
    struct timespec ts;
    clock_gettime(clock, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

static const char *option(int *argc, char **argv, const char *name, const char *dflt) {
    for (int i = 1; i < *argc - 1; i++) {
        if (!strcmp(argv[i], name)) {
            const char *v = argv[i + 1];
            memmove(argv + i, argv + i + 2, (size_t)(*argc - i - 2) * sizeof(char *));
            *argc -= 2;
            return v;
        }
    }
    return dflt;
}

int main(int argc, char **argv) {
    const char *to = option(&argc, argv, "--to", "tcp://127.0.0.1:5560");
    const char *stream_arg = option(&argc, argv, "--stream", NULL);
    const char *fps_arg = option(&argc, argv, "--fps", NULL);
    int batch = atoi(option(&argc, argv, "--batch", "12"));
    double speed = atof(option(&argc, argv, "--speed", "1"));
    const char *units = option(&argc, argv, "--units", "mm");
    const char *up = option(&argc, argv, "--up", "y");
    const char *keydir = option(&argc, argv, "--keys", NULL);
    if (argc != 2 || argv[1][0] == '-' || batch < 1 || speed < 0) {
        fprintf(stderr, "usage: %s TAKE.csv [--to ENDPOINT] [--stream ID] [--fps HZ] "
                "[--batch N] [--speed X] [--units mm] [--up y] [--keys DIR]\n", argv[0]);
        return 2;
    }
    const char *path = argv[1];
    Take t = read_csv(path);
    double fps = fps_arg ? atof(fps_arg) : t.fps;
    if (!(fps > 0)) die(2, "%s: %s", path, "no time column gives the frame rate: give --fps HZ");
    char stream[129];
    if (stream_arg) {
        snprintf(stream, sizeof stream, "%s", stream_arg);
    } else {  /* the file's name without folder and extension */
        const char *base = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
        snprintf(stream, sizeof stream, "%s", base);
        char *dot = strrchr(stream, '.');
        if (dot && dot != stream) *dot = '\0';
    }

    void *ctx = zmq_ctx_new();
    void *sock = zmq_socket(ctx, ZMQ_PUSH);
    int linger = 10000;  /* what is queued at the end still goes out */
    zmq_setsockopt(sock, ZMQ_LINGER, &linger, sizeof linger);
    if (keydir) {
        curve_keys keys = load_keys(keydir);
        use_keys(sock, &keys);
    }
    if (zmq_connect(sock, to) < 0) die(2, "--to %s: %s", to, zmq_strerror(zmq_errno()));

    msgpack_sbuffer buf;
    msgpack_packer pk;
    msgpack_sbuffer_init(&buf);
    msgpack_packer_init(&pk, &buf, msgpack_sbuffer_write);

    pack_head(&pk, "announce", stream, 5);
    pack_str(&pk, "fps");
    msgpack_pack_double(&pk, fps);
    pack_str(&pk, "joints");
    msgpack_pack_array(&pk, (size_t)t.n_joints);
    for (int j = 0; j < t.n_joints; j++) pack_str(&pk, t.joints[j]);
    pack_str(&pk, "parents");  /* unknown in a CSV: the features need only the names */
    msgpack_pack_array(&pk, (size_t)t.n_joints);
    for (int j = 0; j < t.n_joints; j++) msgpack_pack_int(&pk, -1);
    pack_str(&pk, "units");
    pack_str(&pk, units);
    pack_str(&pk, "up");
    pack_str(&pk, up);
    send_message(sock, "announce", stream, &buf);

    size_t per_frame = 3 * (size_t)t.n_joints;
    unsigned char *data = grow(NULL, (size_t)batch * per_frame * 8);
    double t0 = now(CLOCK_REALTIME), m0 = now(CLOCK_MONOTONIC);
    for (size_t seq = 0; seq < t.n_rows; seq += (size_t)batch) {
        size_t n = t.n_rows - seq < (size_t)batch ? t.n_rows - seq : (size_t)batch;
        if (speed > 0) {  /* packet k leaves when its last frame is due */
            double wait = m0 + (double)(seq + n) / fps / speed - now(CLOCK_MONOTONIC);
            if (wait > 0) {
                struct timespec ts = {(time_t)wait, (long)((wait - (time_t)wait) * 1e9)};
                nanosleep(&ts, NULL);
            }
        }
        /* float64 little-endian whatever the host's byte order */
        const double *src = t.values + seq * per_frame;
        for (size_t i = 0; i < n * per_frame; i++) {
            uint64_t bits;
            memcpy(&bits, &src[i], 8);
            for (int b = 0; b < 8; b++) data[8 * i + b] = (unsigned char)(bits >> (8 * b));
        }
        msgpack_sbuffer_clear(&buf);
        pack_head(&pk, "frames", stream, 3);
        pack_str(&pk, "seq");
        msgpack_pack_uint64(&pk, (uint64_t)seq);
        pack_str(&pk, "timestamp");
        msgpack_pack_double(&pk, t0 + (double)seq / fps);
        pack_str(&pk, "positions");
        msgpack_pack_map(&pk, 3);
        pack_str(&pk, "dtype");
        pack_str(&pk, "<f8");
        pack_str(&pk, "shape");
        msgpack_pack_array(&pk, 3);
        msgpack_pack_uint64(&pk, (uint64_t)n);
        msgpack_pack_int(&pk, t.n_joints);
        msgpack_pack_int(&pk, 3);
        pack_str(&pk, "data");
        msgpack_pack_bin(&pk, n * per_frame * 8);
        msgpack_pack_bin_body(&pk, data, n * per_frame * 8);
        send_message(sock, "frames", stream, &buf);
    }
    msgpack_sbuffer_clear(&buf);
    pack_head(&pk, "end", stream, 0);
    send_message(sock, "end", stream, &buf);

    zmq_close(sock);
    zmq_ctx_term(ctx);  /* waits (up to the linger) until the queued messages are out */
    printf("%s: sent %zu frames of %d joints at %g Hz\n", stream, t.n_rows, t.n_joints, fps);
    msgpack_sbuffer_destroy(&buf);
    free(data);
    for (int j = 0; j < t.n_joints; j++) free(t.joints[j]);
    free(t.joints);
    free(t.values);
    return 0;
}
