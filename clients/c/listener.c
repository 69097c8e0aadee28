/* streamseg-listen: print a streamseg daemon's cuts, relabels and closes (protocol v1).
 *
 *   streamseg-listen tcp://127.0.0.1:5561 [STREAM] [--control tcp://127.0.0.1:5562] [--max N]
 *                    [--keys DIR]
 *
 * Subscribes to the topics "cut/", "withdraw/", "segments/" and "closed/" (followed by
 * "STREAM/" when a stream is given: topics are "<type>/<stream>/", filtered by prefix) and
 * prints one line per event, the lines of clients/python/listener.py. With --control it first
 * makes sure the subscription is live (the `hello` handshake of docs/protocol.md: subscribe
 * to "hello/<token>/", ask the daemon to publish that token until it arrives), so nothing
 * published after its first line, "listening on ...", is missed; and it follows every event
 * of the stream (each type; other types get a line "STREAM: TYPE event N"), so the event
 * numbers (`seq`, per stream) show a loss: the missing events are fetched from the daemon's
 * event log (the control op `since`), printed in their place and reported on stderr, as
 * `streamseg listen --control` does; the `stats` heartbeats' `last_seq` show a loss at a
 * stream's end. With a STREAM it stops at that stream's `closed`; else after --max N events
 * (default: never). --keys DIR: CURVE with the keys `streamseg keys DIR` wrote (keys.h).
 *
 * C99 with POSIX, libzmq and msgpack-c. Exit codes: 0 done, 1 a ZeroMQ failure, 2 usage.
 */
#define _POSIX_C_SOURCE 200809L

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <msgpack.h>
#include <zmq.h>

#include "keys.h"

/* The value of `key` in the msgpack map `map`, or NULL. */
static const msgpack_object *get(const msgpack_object *map, const char *key) {
    if (map->type != MSGPACK_OBJECT_MAP) return NULL;
    size_t n = strlen(key);
    for (uint32_t i = 0; i < map->via.map.size; i++) {
        const msgpack_object *k = &map->via.map.ptr[i].key;
        if (k->type == MSGPACK_OBJECT_STR && k->via.str.size == n &&
            !memcmp(k->via.str.ptr, key, n))
            return &map->via.map.ptr[i].val;
    }
    return NULL;
}

static long long int_of(const msgpack_object *o) {
    if (!o) return -1;
    if (o->type == MSGPACK_OBJECT_POSITIVE_INTEGER) return (long long)o->via.u64;
    if (o->type == MSGPACK_OBJECT_NEGATIVE_INTEGER) return (long long)o->via.i64;
    return -1;
}

/* A str field as a C string in `out` (truncated to `size`); "" when absent. */
static const char *str_of(const msgpack_object *o, char *out, size_t size) {
    size_t n = 0;
    if (o && o->type == MSGPACK_OBJECT_STR) {
        n = o->via.str.size < size - 1 ? o->via.str.size : size - 1;
        memcpy(out, o->via.str.ptr, n);
    }
    out[n] = '\0';
    return out;
}

/* Receive one multipart message: topic into `topic`, body into *body (malloc'd). */
static int receive(void *sock, char *topic, size_t size, zmq_msg_t *body) {
    zmq_msg_t part;
    zmq_msg_init(&part);
    if (zmq_msg_recv(&part, sock, 0) < 0) return -1;
    size_t n = zmq_msg_size(&part) < size - 1 ? zmq_msg_size(&part) : size - 1;
    memcpy(topic, zmq_msg_data(&part), n);
    topic[n] = '\0';
    int more = zmq_msg_more(&part);
    zmq_msg_close(&part);
    zmq_msg_init(body);
    if (!more) return 0;  /* not a protocol message (two frames): an empty body */
    if (zmq_msg_recv(body, sock, 0) < 0) return -1;
    while (zmq_msg_more(body)) {  /* extra frames: not ours, drop them */
        zmq_msg_t extra;
        zmq_msg_init(&extra);
        zmq_msg_recv(&extra, sock, 0);
        zmq_msg_close(&extra);
    }
    return 0;
}

/* The `hello` handshake; returns the control REQ socket, kept for `since` requests. */
static void *handshake(void *ctx, void *sub, const char *control, const curve_keys *keys) {
    unsigned char raw[8];
    FILE *r = fopen("/dev/urandom", "rb");
    if (!r || fread(raw, 1, sizeof raw, r) != sizeof raw) {
        fprintf(stderr, "cannot read /dev/urandom for the hello token\n");
        exit(1);
    }
    fclose(r);
    char token[17], topic[32];
    for (int i = 0; i < 8; i++) snprintf(token + 2 * i, 3, "%02x", raw[i]);
    int n = snprintf(topic, sizeof topic, "hello/%s/", token);
    zmq_setsockopt(sub, ZMQ_SUBSCRIBE, topic, (size_t)n);

    msgpack_sbuffer buf;
    msgpack_packer pk;
    msgpack_sbuffer_init(&buf);
    msgpack_packer_init(&pk, &buf, msgpack_sbuffer_write);
    msgpack_pack_map(&pk, 3);
    msgpack_pack_str(&pk, 1);
    msgpack_pack_str_body(&pk, "v", 1);
    msgpack_pack_int(&pk, 1);
    msgpack_pack_str(&pk, 2);
    msgpack_pack_str_body(&pk, "op", 2);
    msgpack_pack_str(&pk, 5);
    msgpack_pack_str_body(&pk, "hello", 5);
    msgpack_pack_str(&pk, 5);
    msgpack_pack_str_body(&pk, "token", 5);
    msgpack_pack_str(&pk, 16);
    msgpack_pack_str_body(&pk, token, 16);

    void *req = zmq_socket(ctx, ZMQ_REQ);
    int linger = 0, wait_ms = 10000;
    zmq_setsockopt(req, ZMQ_LINGER, &linger, sizeof linger);
    zmq_setsockopt(req, ZMQ_RCVTIMEO, &wait_ms, sizeof wait_ms);
    use_keys(req, keys);
    if (zmq_connect(req, control) < 0) {
        fprintf(stderr, "--control %s: %s\n", control, zmq_strerror(zmq_errno()));
        exit(2);
    }
    for (int live = 0; !live;) {
        char reply[256];
        if (zmq_send(req, buf.data, buf.size, 0) < 0 || zmq_recv(req, reply, sizeof reply, 0) < 0) {
            fprintf(stderr, "control %s: %s (is the daemon there%s?)\n", control,
                    zmq_strerror(zmq_errno()), keys ? ", with these keys" : "");
            exit(1);
        }
        zmq_pollitem_t item = {sub, 0, ZMQ_POLLIN, 0};
        while (!live && zmq_poll(&item, 1, 50) > 0) {
            char got[160];
            zmq_msg_t body;
            if (receive(sub, got, sizeof got, &body) < 0) exit(1);
            live = !strcmp(got, topic);  /* (a real client would keep the other events) */
            zmq_msg_close(&body);
        }
    }
    zmq_setsockopt(sub, ZMQ_UNSUBSCRIBE, topic, (size_t)n);
    msgpack_sbuffer_destroy(&buf);
    return req;
}

/* Print one event: -1 when it has no line (stats, hello), 1 when it is the close of the
 * awaited stream, else 0. */
static int print_event(const msgpack_object *ev, const char *only) {
    char type[32], stream[160], reason[64];
    str_of(get(ev, "type"), type, sizeof type);
    str_of(get(ev, "stream"), stream, sizeof stream);
    if (!strcmp(type, "cut")) {
        const msgpack_object *p = get(ev, "pending");
        int pending = p && p->type == MSGPACK_OBJECT_BOOLEAN && p->via.boolean;
        printf("%s: cut at frame %lld (decided at %lld%s)\n", stream,
               int_of(get(ev, "frame")), int_of(get(ev, "emitted_at")),
               pending ? ", pending" : "");
    } else if (!strcmp(type, "withdraw")) {
        printf("%s: withdraw of the cut at frame %lld (at %lld)\n", stream,
               int_of(get(ev, "frame")), int_of(get(ev, "emitted_at")));
    } else if (!strcmp(type, "segments")) {
        printf("%s: relabel %lld of %lld-%lld: ", stream, int_of(get(ev, "revision")),
               int_of(get(ev, "start")), int_of(get(ev, "end")));
        const msgpack_object *segs = get(ev, "segments");
        if (segs && segs->type == MSGPACK_OBJECT_ARRAY) {
            for (uint32_t i = 0; i < segs->via.array.size; i++) {
                const msgpack_object *s = &segs->via.array.ptr[i];
                if (s->type != MSGPACK_OBJECT_ARRAY || s->via.array.size != 3) continue;
                printf("%s%lld-%lld:%lld", i ? ", " : "", int_of(&s->via.array.ptr[0]),
                       int_of(&s->via.array.ptr[1]), int_of(&s->via.array.ptr[2]));
            }
        }
        printf("\n");
    } else if (!strcmp(type, "closed")) {
        printf("%s: closed (%s)\n", stream, str_of(get(ev, "reason"), reason, sizeof reason));
        fflush(stdout);
        return *only != '\0' && !strcmp(stream, only);
    } else if (!strcmp(type, "stats") || !strcmp(type, "hello") || !*type) {
        return -1;
    } else {  /* confirm, rep, gap, error: followed for their numbers */
        printf("%s: %s event %lld\n", *stream ? stream : "*", type, int_of(get(ev, "seq")));
    }
    fflush(stdout);
    return 0;
}

/* The last event number printed of each stream id ("*": daemon-wide), -1: none yet. */
static struct { char id[160]; long long last; } *numbers;
static size_t n_numbers;

static long long *last_of(const char *id) {
    for (size_t i = 0; i < n_numbers; i++)
        if (!strcmp(numbers[i].id, id)) return &numbers[i].last;
    void *grown = realloc(numbers, (n_numbers + 1) * sizeof *numbers);
    if (!grown) {
        fprintf(stderr, "out of memory\n");
        exit(1);
    }
    numbers = grown;
    snprintf(numbers[n_numbers].id, sizeof numbers[n_numbers].id, "%s", id);
    numbers[n_numbers].last = -1;
    return &numbers[n_numbers++].last;
}

static void pack_str(msgpack_packer *pk, const char *s) {
    msgpack_pack_str(pk, strlen(s));
    msgpack_pack_str_body(pk, s, strlen(s));
}

/* Fetch from the event log (control op `since`, page by page) and print the events of
 * `stream` numbered after `after` and below `upto` (-1: all); returns how many, -1 when the
 * daemon could not answer (said on stderr). *done: the awaited stream's close was printed. */
static long long fill(void *req, const char *stream, long long after, long long upto,
                      const char *only, long long *printed, int *done) {
    long long got = 0;
    for (int more = 1; more && !*done;) {
        msgpack_sbuffer buf;
        msgpack_packer pk;
        msgpack_sbuffer_init(&buf);
        msgpack_packer_init(&pk, &buf, msgpack_sbuffer_write);
        msgpack_pack_map(&pk, 4);
        pack_str(&pk, "v");
        msgpack_pack_int(&pk, 1);
        pack_str(&pk, "op");
        pack_str(&pk, "since");
        pack_str(&pk, "stream");
        pack_str(&pk, stream);
        pack_str(&pk, "seq");
        msgpack_pack_long_long(&pk, after);
        zmq_msg_t reply;
        zmq_msg_init(&reply);
        int ok = zmq_send(req, buf.data, buf.size, 0) >= 0 && zmq_msg_recv(&reply, req, 0) >= 0;
        msgpack_sbuffer_destroy(&buf);
        if (!ok) {
            fprintf(stderr, "control: %s\n", zmq_strerror(zmq_errno()));
            exit(1);
        }
        msgpack_unpacked up;
        msgpack_unpacked_init(&up);
        size_t off = 0;
        more = 0;
        if (msgpack_unpack_next(&up, zmq_msg_data(&reply), zmq_msg_size(&reply), &off) !=
            MSGPACK_UNPACK_SUCCESS) {
            got = -1;
        } else if (!get(&up.data, "ok") || !get(&up.data, "ok")->via.boolean) {
            char error[512];
            fprintf(stderr, "since: %s\n", str_of(get(&up.data, "error"), error, sizeof error));
            got = -1;
        } else {
            const msgpack_object *evs = get(&up.data, "events");
            const msgpack_object *m = get(&up.data, "more");
            more = m && m->type == MSGPACK_OBJECT_BOOLEAN && m->via.boolean;
            for (uint32_t i = 0; evs && evs->type == MSGPACK_OBJECT_ARRAY &&
                                 i < evs->via.array.size; i++) {
                const msgpack_object *ev = &evs->via.array.ptr[i];
                long long n = int_of(get(ev, "seq"));
                if (upto >= 0 && n >= upto) {
                    more = 0;
                    break;
                }
                after = n;
                got++;
                int r = print_event(ev, only);
                if (r >= 0) (*printed)++;
                if (r == 1) *done = 1;
                if (*done) break;
            }
        }
        msgpack_unpacked_destroy(&up);
        zmq_msg_close(&reply);
        if (got < 0) return -1;
    }
    return got;
}

/* Events `first`..`end - 1` of `id` were missed: fetched and printed (with a control
 * socket, and not daemon-wide ones: those the subscription may not all hold), and said. */
static void on_hole(void *req, const char *id, long long first, long long end,
                    const char *only, long long *printed, int *done) {
    if (!req || !strcmp(id, "*")) {
        fprintf(stderr, "hole: events %lld..%lld of stream %s were missed (%lld)%s\n", first,
                end - 1, id, end - first, req ? "" : "; give --control to fetch them");
        return;
    }
    long long got = fill(req, id, first - 1, end, only, printed, done);
    if (got < 0)
        fprintf(stderr, "hole: events %lld..%lld of stream %s were missed; cannot fetch them\n",
                first, end - 1, id);
    else
        fprintf(stderr, "hole: events %lld..%lld of stream %s: %lld fetched from the event "
                "log\n", first, end - 1, id, got);
}

/* One received event: its number checked (a hole filled first), then printed. */
static void take(void *req, const msgpack_object *ev, const char *only, long long *printed,
                 int *done) {
    char type[32], id[160];
    str_of(get(ev, "type"), type, sizeof type);
    str_of(get(ev, "stream"), id, sizeof id);
    if (!*id) snprintf(id, sizeof id, "*");
    if (req && !strcmp(type, "stats")) {  /* the heartbeat's numbers: a loss at a tail */
        const msgpack_object *m = get(ev, "last_seq");
        for (uint32_t i = 0; m && m->type == MSGPACK_OBJECT_MAP && i < m->via.map.size &&
                             !*done; i++) {
            char key[160];
            str_of(&m->via.map.ptr[i].key, key, sizeof key);
            long long newest = int_of(&m->via.map.ptr[i].val), *last = last_of(key);
            if (*last >= 0 && newest > *last && (!*only || !strcmp(key, only))) {
                on_hole(req, key, *last + 1, newest + 1, only, printed, done);
                *last = newest;
            }
        }
        return;
    }
    long long n = int_of(get(ev, "seq"));
    if (n >= 0) {
        long long *last = last_of(id);
        if (*last >= 0 && n <= *last) return;  /* printed already, from the log */
        if (*last >= 0 && n > *last + 1) on_hole(req, id, *last + 1, n, only, printed, done);
        *last = n;
        if (*done) return;
    }
    int r = print_event(ev, only);
    if (r >= 0) (*printed)++;
    if (r == 1) *done = 1;
}

int main(int argc, char **argv) {
    const char *endpoint = NULL, *only = "", *control = NULL, *keydir = NULL;
    long long limit = -1;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--control") && i + 1 < argc) control = argv[++i];
        else if (!strcmp(argv[i], "--max") && i + 1 < argc) limit = atoll(argv[++i]);
        else if (!strcmp(argv[i], "--keys") && i + 1 < argc) keydir = argv[++i];
        else if (argv[i][0] == '-') endpoint = NULL, i = argc;  /* unknown option: usage */
        else if (!endpoint) endpoint = argv[i];
        else only = argv[i];
    }
    if (!endpoint) {
        fprintf(stderr, "usage: %s ENDPOINT [STREAM] [--control ENDPOINT] [--max N] "
                "[--keys DIR]\n", argv[0]);
        return 2;
    }
    curve_keys loaded, *keys = NULL;
    if (keydir) {
        loaded = load_keys(keydir);
        keys = &loaded;
    }
    void *ctx = zmq_ctx_new();
    void *sub = zmq_socket(ctx, ZMQ_SUB);
    use_keys(sub, keys);
    if (zmq_connect(sub, endpoint) < 0) {
        fprintf(stderr, "%s: %s\n", endpoint, zmq_strerror(zmq_errno()));
        return 2;
    }
    /* with --control every type of the stream (its numbers must show a loss) and the
     * heartbeats (a loss at its end); without, the four this listener prints */
    const char *kinds[] = {"cut", "withdraw", "segments", "closed", "confirm", "rep", "gap",
                           "error"};
    if (control && !*only) {
        zmq_setsockopt(sub, ZMQ_SUBSCRIBE, "", 0);
    } else {
        for (int k = 0; k < (control ? 8 : 4); k++) {
            char topic[200];
            int n = snprintf(topic, sizeof topic, "%s/%s%s", kinds[k], only, *only ? "/" : "");
            zmq_setsockopt(sub, ZMQ_SUBSCRIBE, topic, (size_t)n);
        }
        if (control) zmq_setsockopt(sub, ZMQ_SUBSCRIBE, "stats/", 6);
    }
    void *req = control ? handshake(ctx, sub, control, keys) : NULL;
    printf("listening on %s\n", endpoint);
    fflush(stdout);
    long long printed = 0;
    for (int done = 0; !done && (limit < 0 || printed < limit);) {
        char topic[200];
        zmq_msg_t body;
        if (receive(sub, topic, sizeof topic, &body) < 0) {
            fprintf(stderr, "receive: %s\n", zmq_strerror(zmq_errno()));
            return 1;
        }
        msgpack_unpacked up;
        msgpack_unpacked_init(&up);
        size_t off = 0;
        if (msgpack_unpack_next(&up, zmq_msg_data(&body), zmq_msg_size(&body), &off) ==
            MSGPACK_UNPACK_SUCCESS) {
            long long v = int_of(get(&up.data, "v"));
            if (v != 1) fprintf(stderr, "skipping protocol version %lld\n", v);
            else take(req, &up.data, only, &printed, &done);
        }
        msgpack_unpacked_destroy(&up);
        zmq_msg_close(&body);
    }
    if (req) zmq_close(req);
    zmq_close(sub);
    zmq_ctx_term(ctx);
    free(numbers);
    return 0;
}
