// SPDX-License-Identifier: MIT
/*
 * recload.c - a recording read whole and indexed. See recload.h.
 */
#include "record/recload.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static int grow(void **p, size_t *cap, size_t n, size_t size)
{
	void *np;
	size_t nc;

	if (n < *cap)
		return 0;
	nc = *cap ? 2 * *cap : 1024;
	np = realloc(*p, nc * size);
	if (!np)
		return -1;
	*p = np;
	*cap = nc;
	return 0;
}

/* a REMOTE record: its message kept, its avatar found or added */
static int add_remote(struct rec_index *ix, const struct recfile_record *rec, size_t *cap, size_t *cap_bytes,
		      size_t *used_bytes)
{
	const uint8_t *msg = rec->payload + RECFILE_MESSAGE_HEAD;
	size_t n = rec->len - RECFILE_MESSAGE_HEAD;
	struct wire_describe d;
	struct wire_frame f;
	struct rec_remote *r;
	uint32_t a;

	if (rec->len < RECFILE_MESSAGE_HEAD || n > WIRE_MAX_MSG)
		return 1;
	if (wire_decode_frame(msg, n, &f) == 0) {
		d.h = f.h;
	} else if (wire_decode_describe(msg, n, &d) != 0) {
		return 1;
	}
	for (a = 0; a < ix->n_remote_avatars && ix->remote_avatars[a].id != d.h.avatar_id; a++)
		;
	if (a == ix->n_remote_avatars) {
		size_t acap = ix->n_remote_avatars;
		void *np = realloc(ix->remote_avatars, (acap + 1) * sizeof(*ix->remote_avatars));

		if (!np)
			return -1;
		ix->remote_avatars = np;
		memset(&ix->remote_avatars[a], 0, sizeof(ix->remote_avatars[a]));
		ix->remote_avatars[a].id = d.h.avatar_id;
		ix->n_remote_avatars++;
	}
	if (d.h.type == WIRE_DESCRIBE && !ix->remote_avatars[a].name[0])
		snprintf(ix->remote_avatars[a].name, sizeof(ix->remote_avatars[a].name), "%s", d.avatar_name);
	if (d.h.type == WIRE_FRAME)
		ix->remote_avatars[a].frames++;
	if (grow((void **)&ix->remote, cap, ix->n_remote, sizeof(*ix->remote)))
		return -1;
	while (*used_bytes + n > *cap_bytes) {
		size_t nc = *cap_bytes ? 2 * *cap_bytes : 65536;
		void *np = realloc(ix->remote_bytes, nc);

		if (!np)
			return -1;
		ix->remote_bytes = np;
		*cap_bytes = nc;
	}
	memcpy(ix->remote_bytes + *used_bytes, msg, n);
	r = &ix->remote[ix->n_remote++];
	r->mono_ns = recfile_get64(rec->payload);
	r->off = *used_bytes;
	r->len = (uint16_t)n;
	r->type = d.h.type;
	r->avatar = a;
	*used_bytes += n;
	return 0;
}

/* the flat names of the first session */
static int names_from_session(struct rec_index *ix)
{
	const struct recfile_session *s = &ix->session;
	uint32_t n = 0, k = 0;

	for (int i = 0; i < s->n_sources; i++)
		n += s->sources[i].n_sensors;
	ix->names = calloc((size_t)n + 1, sizeof(*ix->names));
	if (!ix->names)
		return -1;
	ix->n_sensors = n;
	for (int i = 0; i < s->n_sources; i++) {
		const struct recfile_source *src = &s->sources[i];

		for (uint32_t j = 0; j < src->n_sensors; j++, k++) {
			size_t l = strlen(src->name) + strlen(src->sensor[j]) + 2;

			ix->names[k] = malloc(l);
			if (!ix->names[k])
				return -1;
			snprintf(ix->names[k], l, "%s.%s", src->name, src->sensor[j]);
		}
	}
	return 0;
}

int rec_index_sensor(const struct rec_index *ix, const char *name)
{
	for (uint32_t i = 0; i < ix->n_sensors; i++)
		if (!strcmp(ix->names[i], name))
			return (int)i;
	return -1;
}

/*
 * The map of a session's sensors to flat indices of the first session, by
 * name (-1 where the first session has no such sensor): map[base[i] + j]
 * for sensor j of source i, which has cnt[i] sensors.
 */
struct smap {
	int n_src;
	uint32_t *base, *cnt;
	int *map;
};

static void smap_free(struct smap *m)
{
	free(m->base);
	free(m->cnt);
	free(m->map);
	memset(m, 0, sizeof(*m));
}

static int smap_build(const struct rec_index *ix, const struct recfile_session *s, struct smap *m)
{
	uint32_t n = 0;

	smap_free(m);
	m->n_src = s->n_sources;
	m->base = calloc((size_t)s->n_sources + 1, sizeof(*m->base));
	m->cnt = calloc((size_t)s->n_sources + 1, sizeof(*m->cnt));
	if (!m->base || !m->cnt)
		return -1;
	for (int i = 0; i < s->n_sources; i++) {
		m->base[i] = n;
		m->cnt[i] = s->sources[i].n_sensors;
		n += s->sources[i].n_sensors;
	}
	m->map = calloc((size_t)n + 1, sizeof(*m->map));
	if (!m->map)
		return -1;
	for (int i = 0; i < s->n_sources; i++)
		for (uint32_t j = 0; j < s->sources[i].n_sensors; j++) {
			char name[2 * RECFILE_NAME_MAX + 2];

			snprintf(name, sizeof(name), "%s.%s", s->sources[i].name, s->sources[i].sensor[j]);
			m->map[m->base[i] + j] = rec_index_sensor(ix, name);
		}
	return 0;
}

int rec_index_parse(const uint8_t *buf, size_t len, struct rec_index *ix, char *err, size_t errlen)
{
	size_t off = RECFILE_HEADER_LEN, cap_ev = 0, cap_dmg = 0, cap_rem = 0, cap_bytes = 0, used_bytes = 0;
	struct recfile_record rec;
	struct recfile_damage dmg;
	struct smap m = { 0 };
	uint32_t last_type = 0;
	bool have_session = false;
	int rc;

	memset(ix, 0, sizeof(*ix));
	ix->file_size = len;
	rc = recfile_header_decode(buf, len, &ix->hdr);
	if (rc) {
		snprintf(err, errlen, "%s",
			 rc == -1   ? "not an avatargw recording (no magic)"
			 : rc == -2 ? "the file header is damaged (CRC)"
				    : "a recording of an unknown format version");
		return -1;
	}
	for (;;) {
		int got = recfile_next(buf, len, &off, &rec, &dmg);

		if (dmg.len) {
			if (grow((void **)&ix->damage, &cap_dmg, ix->n_damage, sizeof(*ix->damage)))
				goto nomem;
			ix->damage[ix->n_damage++] = dmg;
			ix->damaged_bytes += dmg.len;
			ix->truncated = dmg.truncated;
		}
		if (!got)
			break;
		last_type = rec.type;
		switch (rec.type) {
		case RECFILE_SESSION: {
			struct recfile_session sess;

			if (recfile_session_parse(rec.payload, rec.len, &sess)) {
				ix->n_bad++;
				break;
			}
			ix->n_sessions++;
			if (!have_session) {
				ix->session = sess;
				have_session = true;
				if (names_from_session(ix) || smap_build(ix, &ix->session, &m))
					goto nomem;
			} else {
				rc = smap_build(ix, &sess, &m);
				recfile_session_free(&sess);
				if (rc)
					goto nomem;
			}
			break;
		}
		case RECFILE_SAMPLE: {
			struct recfile_sample s;
			struct rec_event *e;
			int flat;

			if (recfile_sample_decode(rec.payload, rec.len, &s)) {
				ix->n_bad++;
				break;
			}
			if (!have_session) {
				snprintf(err, errlen, "a sample at byte %zu comes before any SESSION record", rec.off);
				goto fail;
			}
			if (s.source >= m.n_src || s.sensor >= m.cnt[s.source]) {
				ix->n_bad++;
				break;
			}
			flat = m.map[m.base[s.source] + s.sensor];
			if (flat < 0) {
				ix->n_unmapped++;
				break;
			}
			if (grow((void **)&ix->events, &cap_ev, ix->n_events, sizeof(*ix->events)))
				goto nomem;
			e = &ix->events[ix->n_events++];
			e->arrival_ns = s.arrival_ns;
			e->t_ns = s.t_ns;
			e->sensor = (uint32_t)flat;
			e->buttons = s.buttons;
			memcpy(e->p, s.p, sizeof(e->p));
			memcpy(e->q, s.q, sizeof(e->q));
			memcpy(e->analog, s.analog, sizeof(e->analog));
			break;
		}
		case RECFILE_MESSAGE:
			ix->n_messages++;
			break;
		case RECFILE_GAP: {
			struct recfile_gap g;

			if (recfile_gap_decode(rec.payload, rec.len, &g)) {
				ix->n_bad++;
				break;
			}
			ix->n_gaps++;
			ix->lost_records += g.records;
			break;
		}
		case RECFILE_END:
			break;
		case RECFILE_REMOTE:
			rc = add_remote(ix, &rec, &cap_rem, &cap_bytes, &used_bytes);
			if (rc < 0)
				goto nomem;
			ix->n_bad += (size_t)rc;
			break;
		default:
			/* a record type of a later minor version: skipped */
			ix->n_other++;
			break;
		}
	}
	ix->clean_end = last_type == RECFILE_END && !ix->truncated &&
			(!ix->n_damage || ix->damage[ix->n_damage - 1].off + ix->damage[ix->n_damage - 1].len < len);
	smap_free(&m);
	if (!have_session) {
		snprintf(err, errlen, "no SESSION record (an empty or unreadable recording)");
		rec_index_free(ix);
		return -1;
	}
	return 0;
nomem:
	snprintf(err, errlen, "out of memory");
fail:
	smap_free(&m);
	rec_index_free(ix);
	return -1;
}

int rec_index_load(const char *path, struct rec_index *ix, char *err, size_t errlen)
{
	int fd = open(path, O_RDONLY | O_CLOEXEC);
	struct stat st;
	uint8_t *buf;
	size_t got = 0;
	char why[256];
	int rc;

	memset(ix, 0, sizeof(*ix));
	if (fd < 0 || fstat(fd, &st)) {
		snprintf(err, errlen, "%s: %s", path, strerror(errno));
		if (fd >= 0)
			close(fd);
		return -1;
	}
	buf = malloc((size_t)st.st_size + 1);
	if (!buf) {
		close(fd);
		snprintf(err, errlen, "%s: out of memory (%lld bytes)", path, (long long)st.st_size);
		return -1;
	}
	while (got < (size_t)st.st_size) {
		ssize_t n = read(fd, buf + got, (size_t)st.st_size - got);

		if (n < 0 && errno == EINTR)
			continue;
		if (n <= 0)
			break;
		got += (size_t)n;
	}
	close(fd);
	rc = rec_index_parse(buf, got, ix, why, sizeof(why));
	free(buf);
	if (rc)
		snprintf(err, errlen, "%s: %s", path, why);
	return rc;
}

void rec_index_free(struct rec_index *ix)
{
	for (uint32_t i = 0; ix->names && i < ix->n_sensors; i++)
		free(ix->names[i]);
	free(ix->names);
	free(ix->events);
	free(ix->damage);
	free(ix->remote);
	free(ix->remote_bytes);
	free(ix->remote_avatars);
	recfile_session_free(&ix->session);
	memset(ix, 0, sizeof(*ix));
}

int rec_index_person(const struct rec_index *ix, const char *person, int sensor[3], char *label, size_t llen, char *err,
		     size_t errlen)
{
	static const char *const roles[3] = { "head", "left_hand", "right_hand" };
	char prefix[2 * RECFILE_NAME_MAX + 2];

	if (!person) {
		const struct recfile_session *s = &ix->session;

		if (!s->n_avatars) {
			snprintf(err, errlen,
				 "the recording names no avatar: give the person (SOURCE or SOURCE/PREFIX)");
			return -1;
		}
		for (int r = 0; r < 3; r++) {
			const struct recfile_source *src = &s->sources[s->avatars[0].source[r]];
			char name[2 * RECFILE_NAME_MAX + 2];

			snprintf(name, sizeof(name), "%s.%s", src->name, src->sensor[s->avatars[0].sensor[r]]);
			sensor[r] = rec_index_sensor(ix, name);
			if (sensor[r] < 0) {
				snprintf(err, errlen, "sensor %s of avatar %s is not in the recording", name,
					 s->avatars[0].name);
				return -1;
			}
		}
		snprintf(label, llen, "avatar %s", s->avatars[0].name);
		return 0;
	}
	snprintf(prefix, sizeof(prefix), "%s", person);
	for (char *c = prefix; *c; c++)
		if (*c == '/')
			*c = '.';
	for (int r = 0; r < 3; r++) {
		char name[2 * RECFILE_NAME_MAX + 16];

		snprintf(name, sizeof(name), "%s.%s", prefix, roles[r]);
		sensor[r] = rec_index_sensor(ix, name);
		if (sensor[r] < 0) {
			snprintf(err, errlen, "no sensor %s in the recording", name);
			return -1;
		}
	}
	snprintf(label, llen, "%s", person);
	return 0;
}
