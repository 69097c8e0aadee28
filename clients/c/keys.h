/* CURVE for the C clients: the Z85 keys of the files `streamseg keys DIR` writes.
 *
 * DIR/client.key_secret holds this client's pair (`public-key = "..."`, `secret-key =
 * "..."`), DIR/server.key the daemon's public key: ZeroMQ's certificate files, whose key
 * lines are all a client reads. use_keys() sets ZMQ_CURVE_SERVERKEY, _PUBLICKEY and
 * _SECRETKEY on a socket before it connects; every socket of a client to a CURVE daemon
 * needs them (the daemon's own key is its identity; the client's must be in the daemon's
 * authorized/ folder). C99 with libzmq; a missing or unreadable file exits with code 2.
 */
#ifndef STREAMSEG_KEYS_H
#define STREAMSEG_KEYS_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <zmq.h>

typedef struct {
    char public_key[41], secret_key[41], server_key[41];
} curve_keys;

/* The Z85 value of `name = "..."` in the certificate file `path` into out (41 bytes). */
static int key_line(const char *path, const char *name, char *out) {
    FILE *f = fopen(path, "r");
    if (!f) return -1;
    char line[256];
    int found = -1;
    size_t n = strlen(name);
    while (found < 0 && fgets(line, sizeof line, f)) {
        const char *p = line;
        while (*p == ' ' || *p == '\t') p++;
        if (strncmp(p, name, n)) continue;
        p = strchr(p + n, '"');
        if (p && strlen(p + 1) > 40 && p[41] == '"') {
            memcpy(out, p + 1, 40);
            out[40] = '\0';
            found = 0;
        }
    }
    fclose(f);
    return found;
}

/* Read DIR/client.key_secret and DIR/server.key; exits 2 saying which file is wrong. */
static curve_keys load_keys(const char *dir) {
    curve_keys k;
    char path[4096];
    snprintf(path, sizeof path, "%s/client.key_secret", dir);
    if (key_line(path, "public-key", k.public_key) || key_line(path, "secret-key", k.secret_key)) {
        fprintf(stderr, "--keys %s: %s has no CURVE key pair (make one with `streamseg keys "
                "DIR`)\n", dir, path);
        exit(2);
    }
    snprintf(path, sizeof path, "%s/server.key", dir);
    if (key_line(path, "public-key", k.server_key)) {
        fprintf(stderr, "--keys %s: %s has no public key of the daemon (`streamseg keys DIR` "
                "writes it)\n", dir, path);
        exit(2);
    }
    if (!zmq_has("curve")) {
        fprintf(stderr, "--keys: this libzmq has no CURVE (build it with libsodium)\n");
        exit(2);
    }
    return k;
}

/* CURVE on `sock` (before it connects); nothing when keys is NULL. */
static void use_keys(void *sock, const curve_keys *keys) {
    if (!keys) return;
    zmq_setsockopt(sock, ZMQ_CURVE_SERVERKEY, keys->server_key, 40);
    zmq_setsockopt(sock, ZMQ_CURVE_PUBLICKEY, keys->public_key, 40);
    zmq_setsockopt(sock, ZMQ_CURVE_SECRETKEY, keys->secret_key, 40);
}

#endif
