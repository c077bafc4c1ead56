/* SPDX-License-Identifier: MIT */
/*
 * recload.h - a whole recording read into memory and indexed: its header,
 * its first SESSION (the sensors' names), every sample in file order, and
 * what was wrong with the file (damaged regions, a cut-off end, records
 * lost to a full buffer while recording), and the remote avatars'
 * messages ([site]). Used at start-up by the replay
 * source and by the tools; never by the loop.
 *
 * Sensors are named "SOURCE.SENSOR" after the first SESSION record
 * (clip.head, sim.p0.left_hand). A later SESSION (the daemon reloaded its
 * configuration) is matched to these names; samples of sensors the first
 * SESSION did not have are counted as unmapped and left out.
 */
#ifndef AGW_RECLOAD_H
#define AGW_RECLOAD_H

#include "avatargw/wire.h"
#include "record/recfile.h"

struct rec_event {
	uint64_t arrival_ns; /* CLOCK_MONOTONIC of the recording daemon */
	uint64_t t_ns;	     /* the tracker's sample time */
	uint32_t sensor;     /* index into rec_index.names */
	uint32_t buttons;
	float p[3];
	float q[4];
	float analog[4];
};

/* a remote avatar's message ([site]: RECFILE_REMOTE), its bytes in rec_index.remote_bytes */
struct rec_remote {
	uint64_t mono_ns; /* the recording daemon's cycle, CLOCK_MONOTONIC */
	size_t off;	  /* into remote_bytes */
	uint16_t len;
	uint8_t type;	 /* WIRE_FRAME or WIRE_DESCRIBE */
	uint32_t avatar; /* index into rec_index.remote_avatars */
};

/* a remote avatar of the recording: its id and name as the recording daemon published them */
struct rec_remote_avatar {
	uint16_t id;
	char name[WIRE_NAME_MAX + 1]; /* its first DESCRIBE's, "SITE/NAME" ("" before one) */
	size_t frames;
};

struct rec_index {
	struct recfile_header hdr;
	struct recfile_session session; /* the first */
	uint32_t n_sensors;
	char **names; /* n_sensors, "SOURCE.SENSOR" */
	size_t n_events;
	struct rec_event *events; /* every sample, in file order */
	size_t n_sessions, n_messages, n_gaps, n_other;
	uint64_t lost_records; /* summed over GAP records */
	size_t n_unmapped;     /* samples of sensors not in the first SESSION */
	size_t n_bad;	       /* good CRC but a payload that does not decode */
	size_t n_damage;
	struct recfile_damage *damage; /* regions that were skipped, in file order */
	size_t damaged_bytes;
	bool truncated; /* the file ends inside a record */
	bool clean_end; /* the last record is an END */
	size_t file_size;
	/* remote avatars ([site]): their FRAMEs and DESCRIBEs in file order, and who they are */
	size_t n_remote;
	struct rec_remote *remote;
	uint8_t *remote_bytes;
	size_t n_remote_avatars;
	struct rec_remote_avatar *remote_avatars;
};

/*
 * Parses buf (a whole recording). 0, or -1 with err: not a recording, a
 * damaged or unknown header, no SESSION before the first sample, no memory.
 * Damage after the header is not an error: it is listed in ix.
 */
int rec_index_parse(const uint8_t *buf, size_t len, struct rec_index *ix, char *err, size_t errlen);
/* reads path whole and parses it; "path: ..." in err */
int rec_index_load(const char *path, struct rec_index *ix, char *err, size_t errlen);
void rec_index_free(struct rec_index *ix);
/* the index of a sensor name, or -1 */
int rec_index_sensor(const struct rec_index *ix, const char *name);
/*
 * The head, left-hand and right-hand sensors of a person: NULL for the
 * first avatar of the SESSION; "SRC" for SRC.head, SRC.left_hand,
 * SRC.right_hand; "SRC/PREFIX" for SRC.PREFIX.head, ... (an avatar's person
 * key, as in the configuration of the recording daemon). label gets a
 * printable name. 0 or -1 with err.
 */
int rec_index_person(const struct rec_index *ix, const char *person, int sensor[3], char *label, size_t llen, char *err,
		     size_t errlen);

#endif /* AGW_RECLOAD_H */
