/* streamseg-listen: print a streamseg daemon's cuts, relabels and closes (protocol v1).
 *
 *   streamseg-listen tcp://127.0.0.1:5561 [STREAM] [--control tcp://127.0.0.1:5562] [--max N]
 *
 * Subscribes to the topics "cut/", "withdraw/", "segments/" and "closed/" (followed by
 * "STREAM/" when a stream is given: topics are "<type>/<stream>/", filtered by prefix) and
 * prints one line per event, the lines of clients/python/listener.py. With --control it first
 * makes sure the subscription is live (the `hello` handshake of docs/protocol.md: subscribe
 * to "hello/<token>/", ask the daemon to publish that token until it arrives), so nothing
 * published after its first line, "listening on ...", is missed. With a STREAM it stops at
 * that stream's `closed`; else after --max N events (default: never).
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

static void handshake(void *ctx, void *sub, const char *control) {
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
    int linger = 0;
    zmq_setsockopt(req, ZMQ_LINGER, &linger, sizeof linger);
    if (zmq_connect(req, control) < 0) {
        fprintf(stderr, "--control %s: %s\n", control, zmq_strerror(zmq_errno()));
        exit(2);
    }
    for (int live = 0; !live;) {
        char reply[256];
        if (zmq_send(req, buf.data, buf.size, 0) < 0 || zmq_recv(req, reply, sizeof reply, 0) < 0) {
            fprintf(stderr, "control: %s\n", zmq_strerror(zmq_errno()));
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
    zmq_close(req);
    zmq_setsockopt(sub, ZMQ_UNSUBSCRIBE, topic, (size_t)n);
    msgpack_sbuffer_destroy(&buf);
}

/* Print one event; returns 1 when it is the close of the awaited stream. */
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
        return *only != '\0';
    }
    fflush(stdout);
    return 0;
}

int main(int argc, char **argv) {
    const char *endpoint = NULL, *only = "", *control = NULL;
    long long limit = -1;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--control") && i + 1 < argc) control = argv[++i];
        else if (!strcmp(argv[i], "--max") && i + 1 < argc) limit = atoll(argv[++i]);
        else if (argv[i][0] == '-') endpoint = NULL, i = argc;  /* unknown option: usage */
        else if (!endpoint) endpoint = argv[i];
        else only = argv[i];
    }
    if (!endpoint) {
        fprintf(stderr, "usage: %s ENDPOINT [STREAM] [--control ENDPOINT] [--max N]\n", argv[0]);
        return 2;
    }
    void *ctx = zmq_ctx_new();
    void *sub = zmq_socket(ctx, ZMQ_SUB);
    if (zmq_connect(sub, endpoint) < 0) {
        fprintf(stderr, "%s: %s\n", endpoint, zmq_strerror(zmq_errno()));
        return 2;
    }
    const char *kinds[] = {"cut", "withdraw", "segments", "closed"};
    for (int k = 0; k < 4; k++) {
        char topic[160];
        int n = snprintf(topic, sizeof topic, "%s/%s%s", kinds[k], only, *only ? "/" : "");
        zmq_setsockopt(sub, ZMQ_SUBSCRIBE, topic, (size_t)n);
    }
    if (control) handshake(ctx, sub, control);
    printf("listening on %s\n", endpoint);
    fflush(stdout);
    for (long long seen = 0; limit < 0 || seen < limit;) {
        char topic[160];
        zmq_msg_t body;
        if (receive(sub, topic, sizeof topic, &body) < 0) {
            fprintf(stderr, "receive: %s\n", zmq_strerror(zmq_errno()));
            return 1;
        }
        msgpack_unpacked up;
        msgpack_unpacked_init(&up);
        size_t off = 0;
        int done = 0;
        if (msgpack_unpack_next(&up, zmq_msg_data(&body), zmq_msg_size(&body), &off) ==
            MSGPACK_UNPACK_SUCCESS) {
            long long v = int_of(get(&up.data, "v"));
            if (v != 1) {
                fprintf(stderr, "skipping protocol version %lld\n", v);
            } else {
                seen++;
                done = print_event(&up.data, only);
            }
        }
        msgpack_unpacked_destroy(&up);
        zmq_msg_close(&body);
        if (done) break;
    }
    zmq_close(sub);
    zmq_ctx_term(ctx);
    return 0;
}
