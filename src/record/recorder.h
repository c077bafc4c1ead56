/* SPDX-License-Identifier: MIT */
/*
 * recorder.h - the daemon records its sessions (docs/RECORDING.md).
 *
 * The loop never touches a file: every sample a tracker takes in
 * (tracker_put) and, if asked, every published message is encoded into a
 * preallocated lock-free single-producer single-consumer ring; a writer
 * thread takes the records out, seals them with their CRC and appends them
 * to the current file under the flush policy, and rotates files by size or
 * age. A full ring drops the record and counts it (the writer then marks the
 * gap in the file); the loop never waits.
 *
 * Threads: recorder_open/attach/close and the stats readers run in the
 * control thread; recorder_sample/recorder_message in the loop (the one
 * producer; attach pushes only while the loop is paused or not yet
 * started); the writer thread is the consumer.
 */
#ifndef AGW_RECORDER_H
#define AGW_RECORDER_H

#include "config/config.h"

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

struct recfile_sample;
struct recorder;

struct recorder_stats {
	_Atomic uint64_t records;	  /* written to files */
	_Atomic uint64_t bytes;		  /* written to files, headers included */
	_Atomic uint64_t dropped_records; /* lost to a full ring (loop side) */
	_Atomic uint64_t dropped_bytes;
	_Atomic uint64_t skipped_records; /* not written: no file could be opened, or a write failed */
	_Atomic uint64_t write_errors;	  /* failed open/write/fsync calls */
	_Atomic uint64_t files;		  /* files opened */
	_Atomic uint64_t flushes;	  /* write() batches */
	_Atomic int last_errno;
};

/*
 * Start-up (control thread): the ring of d->record_buffer KiB, the writer
 * thread, the first file in d->record_dir (created if missing). A file that
 * cannot be opened is not fatal: the writer retries every second and counts.
 * Returns 0 or a negative errno with err set (no memory, no thread).
 */
int recorder_open(struct recorder **rp, const struct cfg_daemon *d, char *err, size_t errlen);
/* Stops the writer after it has written everything queued, an END record last. NULL is fine. */
void recorder_close(struct recorder *r);
/* true if the record_* keys of a and b differ (a reload must reopen the recorder) */
bool recorder_config_changed(const struct cfg_daemon *a, const struct cfg_daemon *b);

/*
 * Control thread, with the loop paused or not started: a SESSION record
 * describing configuration c (sources, sensors, avatars) is queued; the
 * samples and messages that follow are of c (the gateway taps its trackers
 * and messages into recorder_sample and recorder_message). Returns 0 or
 * -ENOSPC if the SESSION record does not fit the ring (raise record_buffer).
 */
int recorder_attach(struct recorder *r, const struct config *c, uint32_t source_id, char *err, size_t errlen);

/* loop: one sample (smp->source: the source's index in the configuration) */
void recorder_sample(struct recorder *r, const struct recfile_sample *smp);
/* loop: one published message, as the wire carries it (recorded only with record_messages) */
void recorder_message(struct recorder *r, uint64_t mono_ns, const uint8_t *data, size_t len);
/*
 * loop: a remote avatar's FRAME (one with a new sample) or DESCRIBE as this
 * daemon publishes it (its avatar id, names and joint angles), always
 * recorded: a replay publishes it again as it was, not solved again
 */
void recorder_remote(struct recorder *r, uint64_t mono_ns, const uint8_t *data, size_t len);

/* control thread */
const struct recorder_stats *recorder_stats(const struct recorder *r);
/* the file being written ("" if none) */
void recorder_current_file(struct recorder *r, char *buf, size_t len);
/* ring fill, bytes used and capacity */
void recorder_ring_use(const struct recorder *r, uint64_t *used, uint64_t *cap);

/*
 * Control thread: opens, reopens (record_* keys changed) or closes *rp as
 * c's [daemon] record_* keys say, and attaches c. With the loop paused or
 * not started. 0 or a negative errno with err.
 */
int recorder_apply(struct recorder **rp, const struct config *c, uint32_t source_id, char *err, size_t errlen);
/* control thread, once a second: logs what changed (new file, drops, errors) */
void recorder_log(struct recorder *r);

#endif /* AGW_RECORDER_H */
