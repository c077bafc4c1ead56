// SPDX-License-Identifier: MIT
/*
 * listen.c - the sockets the server outputs share.
 */
#include "publish/listen.h"

#include <errno.h>
#include <netdb.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

int out_listen_tcp(const char *name, const char *address, int port_no, const char *what, bool reuseport, char *err,
		   size_t errlen)
{
	struct addrinfo hints = { .ai_socktype = SOCK_STREAM, .ai_flags = AI_NUMERICSERV | AI_PASSIVE }, *ai;
	char port[8];
	int fd, one = 1, rc;

	snprintf(port, sizeof(port), "%d", port_no);
	rc = getaddrinfo(address[0] ? address : NULL, port, &hints, &ai);
	if (rc) {
		snprintf(err, errlen, "[output %s] address: %s: %s", name, address, gai_strerror(rc));
		return -EINVAL;
	}
	fd = socket(ai->ai_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
	if (fd < 0 || setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one)) ||
	    (reuseport && setsockopt(fd, SOL_SOCKET, SO_REUSEPORT, &one, sizeof(one))) ||
	    bind(fd, ai->ai_addr, ai->ai_addrlen) || listen(fd, 16)) {
		rc = -errno;
		snprintf(err, errlen, "[output %s]: %s on %s port %d: %s%s", name, what, address, port_no,
			 strerror(errno),
			 errno == EACCES && port_no < 1024 ? " (ports below 1024 need CAP_NET_BIND_SERVICE)" : "");
		if (fd >= 0)
			close(fd);
		freeaddrinfo(ai);
		return rc;
	}
	freeaddrinfo(ai);
	return fd;
}

int out_send_pending(int fd, const uint8_t *buf, size_t *off, size_t *len)
{
	while (*len) {
		ssize_t n = send(fd, buf + *off, *len, MSG_DONTWAIT | MSG_NOSIGNAL);

		if (n > 0) {
			*off += (size_t)n;
			*len -= (size_t)n;
			continue;
		}
		if (n < 0 && errno == EINTR)
			continue;
		if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK))
			return 0;
		return n < 0 ? -errno : -EPIPE;
	}
	*off = 0;
	return 0;
}
