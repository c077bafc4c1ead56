// SPDX-License-Identifier: MIT
/*
 * listen.c - the sockets the server outputs share.
 */
#include "publish/listen.h"

#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

int out_listen_tcp(const char *name, const char *address, int port_no, const char *what, int inherit, char *err,
		   size_t errlen)
{
	struct addrinfo hints = { .ai_socktype = SOCK_STREAM, .ai_flags = AI_NUMERICSERV | AI_PASSIVE }, *ai;
	char port[8];
	int fd, one = 1, rc;

	if (inherit >= 0) {
		/* the same address in the configuration being replaced: its socket, shared until it closes */
		fd = fcntl(inherit, F_DUPFD_CLOEXEC, 0);
		if (fd < 0) {
			rc = -errno;
			snprintf(err, errlen, "[output %s]: %s on %s port %d: %s", name, what, address, port_no,
				 strerror(errno));
		}
		return fd < 0 ? rc : fd;
	}
	snprintf(port, sizeof(port), "%d", port_no);
	rc = getaddrinfo(address[0] ? address : NULL, port, &hints, &ai);
	if (rc) {
		snprintf(err, errlen, "[output %s] address: %s: %s", name, address, gai_strerror(rc));
		return -EINVAL;
	}
	fd = socket(ai->ai_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
	/* SO_REUSEADDR only: a port another process listens on is refused, never shared */
	if (fd < 0 || setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one)) ||
	    bind(fd, ai->ai_addr, ai->ai_addrlen) || listen(fd, 16)) {
		rc = -errno;
		snprintf(err, errlen, "[output %s]: %s on %s port %d: %s%s", name, what, address, port_no,
			 strerror(errno),
			 errno == EACCES && port_no < 1024 ? " (ports below 1024 need CAP_NET_BIND_SERVICE)"
			 : errno == EADDRINUSE		   ? " (another program, or another avatargw, listens there)"
							   : "");
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

/*
 * The Unix sockets this process made, by path: a socket is unlinked when the
 * last descriptor of it closes (a reload may share it between two outputs),
 * and only if the file at its path is still the one we bound.
 */
#define UNIX_MADE_MAX 64

static struct unix_made {
	char path[sizeof(((struct sockaddr_un *)0)->sun_path)];
	dev_t dev;
	ino_t ino;
	int refs;
} unix_made[UNIX_MADE_MAX];

static struct unix_made *unix_find(const char *path)
{
	for (int i = 0; i < UNIX_MADE_MAX; i++)
		if (unix_made[i].refs && !strcmp(unix_made[i].path, path))
			return &unix_made[i];
	return NULL;
}

int out_listen_unix(const char *path, mode_t mode, char *err, size_t errlen)
{
	struct sockaddr_un sun = { .sun_family = AF_UNIX };
	struct unix_made *m = NULL;
	struct stat st;
	int fd, rc;

	if (strlen(path) >= sizeof(sun.sun_path)) {
		snprintf(err, errlen, "%s: longer than %zu characters", path, sizeof(sun.sun_path) - 1);
		return -ENAMETOOLONG;
	}
	strcpy(sun.sun_path, path);
	for (int i = 0; i < UNIX_MADE_MAX && !m; i++)
		if (!unix_made[i].refs)
			m = &unix_made[i];
	if (!m || unix_find(path)) {
		snprintf(err, errlen, "%s: %s", path, m ? "already open in this process" : "too many Unix sockets");
		return m ? -EADDRINUSE : -ENFILE;
	}
	if (lstat(path, &st) == 0) {
		if (!S_ISSOCK(st.st_mode)) {
			snprintf(err, errlen, "%s exists and is not a socket", path);
			return -EEXIST;
		}
		/* a socket left by a run that ended is replaced; one that answers is another process's */
		fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
		if (fd < 0) {
			rc = -errno;
			snprintf(err, errlen, "%s: socket: %s", path, strerror(errno));
			return rc;
		}
		rc = connect(fd, (struct sockaddr *)&sun, sizeof(sun)) ? errno : 0;
		close(fd);
		if (rc != ECONNREFUSED) {
			snprintf(err, errlen, "%s: %s", path,
				 rc ? strerror(rc)
				    : "another process (another avatargw?) listens on this socket: not taking it over");
			return rc ? -rc : -EADDRINUSE;
		}
		if (unlink(path) && errno != ENOENT) {
			rc = -errno;
			snprintf(err, errlen, "%s: cannot remove the socket a previous run left: %s", path,
				 strerror(errno));
			return rc;
		}
	}
	fd = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
	if (fd < 0 || bind(fd, (struct sockaddr *)&sun, sizeof(sun))) {
		rc = -errno;
		snprintf(err, errlen, "%s: %s", path, strerror(errno));
		if (fd >= 0)
			close(fd);
		return rc;
	}
	/* the mode is ours to say, whatever the umask; set before anyone can connect */
	if (lstat(path, &st) || chmod(path, mode) || listen(fd, 16)) {
		rc = -errno;
		snprintf(err, errlen, "%s: %s", path, strerror(errno));
		close(fd);
		unlink(path);
		return rc;
	}
	snprintf(m->path, sizeof(m->path), "%s", path);
	m->dev = st.st_dev;
	m->ino = st.st_ino;
	m->refs = 1;
	return fd;
}

int out_unix_share(int fd, const char *path)
{
	struct unix_made *m = unix_find(path);
	int nfd;

	if (!m)
		return -ENOENT;
	nfd = fcntl(fd, F_DUPFD_CLOEXEC, 0);
	if (nfd < 0)
		return -errno;
	m->refs++;
	return nfd;
}

void out_unix_close(int fd, const char *path)
{
	struct unix_made *m = unix_find(path);
	struct stat st;

	if (fd >= 0)
		close(fd);
	if (!m || --m->refs > 0)
		return;
	if (lstat(path, &st) == 0 && st.st_dev == m->dev && st.st_ino == m->ino)
		unlink(path);
	m->path[0] = '\0';
}

bool out_same_host(const struct sockaddr_storage *a, const struct sockaddr_storage *b)
{
	if (a->ss_family != b->ss_family)
		return false;
	if (a->ss_family == AF_INET)
		return ((const struct sockaddr_in *)a)->sin_addr.s_addr ==
		       ((const struct sockaddr_in *)b)->sin_addr.s_addr;
	if (a->ss_family == AF_INET6)
		return !memcmp(&((const struct sockaddr_in6 *)a)->sin6_addr,
			       &((const struct sockaddr_in6 *)b)->sin6_addr, sizeof(struct in6_addr));
	return a->ss_family == AF_UNSPEC || a->ss_family == AF_UNIX;
}

int out_slot_for(const void *base, size_t stride, size_t fd_off, size_t peer_off, int n,
		 const struct sockaddr_storage *from, int per_addr, uint64_t now_ns, bool *drop)
{
	int free_slot = -1, same = 0, idlest = -1, idlest_same = -1;
	bool host = from && from->ss_family != AF_UNSPEC && from->ss_family != AF_UNIX;

	*drop = false;
	for (int i = 0; i < n; i++) {
		const char *c = (const char *)base + (size_t)i * stride;
		const struct out_peer *p = (const struct out_peer *)(c + peer_off);
		int fd;

		memcpy(&fd, c + fd_off, sizeof(fd));
		if (fd < 0) {
			if (free_slot < 0)
				free_slot = i;
			continue;
		}
		if (idlest < 0 ||
		    p->active_ns < ((const struct out_peer *)((const char *)base + (size_t)idlest * stride + peer_off))
					   ->active_ns)
			idlest = i;
		if (host && out_same_host(&p->addr, from)) {
			same++;
			if (idlest_same < 0 ||
			    p->active_ns < ((const struct out_peer *)((const char *)base +
								      (size_t)idlest_same * stride + peer_off))
						   ->active_ns)
				idlest_same = i;
		}
	}
	if (host && per_addr > 0 && same >= per_addr)
		idlest = idlest_same; /* this address has its share: it gives up one of its own */
	else if (free_slot >= 0)
		return free_slot;
	if (idlest < 0)
		return -1;
	{
		const struct out_peer *p =
			(const struct out_peer *)((const char *)base + (size_t)idlest * stride + peer_off);

		if (now_ns - p->active_ns < OUT_MIN_IDLE_NS)
			return -1;
	}
	*drop = true;
	return idlest;
}
