/* SPDX-License-Identifier: MIT */
/*
 * listen.h - what the server outputs (stream, Modbus, VRPN) and the
 * control socket share: the listening TCP socket (non-blocking,
 * close-on-exec, SO_REUSEADDR, bound to the output's address, empty: every
 * interface, and port), the listening Unix socket, and the non-blocking
 * send of a client's pending bytes.
 */
#ifndef AGW_LISTEN_H
#define AGW_LISTEN_H

#include "config/config.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/socket.h>
#include <sys/types.h>

/*
 * No SO_REUSEPORT: a port in use is an error (EADDRINUSE), never shared
 * with another process. inherit: the listening socket of the same address
 * in the configuration a reload replaces (-1: none), shared (dup) so that
 * the new server opens before the old one closes. what: the server's name
 * in the error ("listen", "Modbus server"). Returns the descriptor, or a
 * negative errno with err saying which output, where and why.
 */
int out_listen_tcp(const char *name, const char *address, int port_no, const char *what, int inherit, char *err,
		   size_t errlen);

/*
 * A listening Unix stream socket at path (non-blocking, close-on-exec) with
 * the file mode given, whatever the umask. A socket file already there is
 * replaced only when nothing listens on it (a run that ended); one that
 * answers is refused (EADDRINUSE), and so is anything that is not a socket.
 * Returns the descriptor, or a negative errno with err saying why.
 */
int out_listen_unix(const char *path, mode_t mode, char *err, size_t errlen);
/* another descriptor of the socket out_listen_unix() made at path (a reload's new output) */
int out_unix_share(int fd, const char *path);
/* closes fd; once the last descriptor is closed, unlinks path if it is still the socket we made */
void out_unix_close(int fd, const char *path);

/*
 * Connection slots. A client's address (its host, without the port) and
 * when it was last active (a request, bytes received: what the listener
 * counts as activity), as each server keeps them in its client slots.
 */
struct out_peer {
	struct sockaddr_storage addr; /* family 0: none (a Unix socket) */
	uint64_t active_ns;	      /* CLOCK_MONOTONIC */
};

#define OUT_MIN_IDLE_NS 1000000000ull /* a client active within the last second is never dropped for another */

/* same host: the same family and address, whatever the ports */
bool out_same_host(const struct sockaddr_storage *a, const struct sockaddr_storage *b);

/*
 * The slot a new client from `from` takes among n slots: clients[i] is at
 * base + i * stride, its descriptor (int, -1 when free) at fd_off and its
 * struct out_peer at peer_off. An address that already holds per_addr
 * clients (0: no limit but n) gives up its client idle the longest; a full
 * listener gives up the client idle the longest of all; either only if that
 * client has been idle OUT_MIN_IDLE_NS. Returns the slot, with *drop true
 * when its client must be dropped first, or -1: refuse the new client.
 */
int out_slot_for(const void *base, size_t stride, size_t fd_off, size_t peer_off, int n,
		 const struct sockaddr_storage *from, int per_addr, uint64_t now_ns, bool *drop);

/*
 * Sends what the socket takes now of the len bytes at buf + *off, without
 * waiting; advances *off and *len (both 0 once all went). 0, or a negative
 * errno when the connection is broken (the caller drops the client).
 */
int out_send_pending(int fd, const uint8_t *buf, size_t *off, size_t *len);

#endif /* AGW_LISTEN_H */
