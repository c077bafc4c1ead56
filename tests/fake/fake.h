/* SPDX-License-Identifier: MIT */
/*
 * fake.h - simulated trackers behind the real library interfaces, for the
 * tests of the hardware drivers (linked into test_hydra and test_polhemus
 * with -Wl,--wrap=... for every hidapi and libusb function the drivers
 * call; see the Makefile).
 *
 * fake_hid.c is a Razer Hydra as hidapi's hidraw back end shows it: two
 * nodes (interfaces 0 and 1), gamepad mode until the motion-mode feature
 * report arrives on interface 1, then 52-byte reports on interface 0,
 * replayed from a capture (tests/data, made by tools/gen-captures.py from
 * real motion). fake_usb.c is a Polhemus Liberty HS as libusb shows it: a
 * device on the bus (before or after its firmware), its descriptors, bulk
 * endpoints 0x04 and 0x88, the ASCII commands it obeys (P F1 U1 H O C) and
 * its continuous binary frames, replayed from a capture; hot-plug events.
 *
 * Both play in one of two ways: free-running (a report every period, the
 * capture played forwards then backwards so the motion stays continuous,
 * the device's sequence numbers counting on) or stepped (a report only
 * when the test releases it: deterministic checks of what comes out). Both
 * take faults from the test: unplug and replug, injected bytes, dropped
 * and damaged reports, stalls, halted endpoints. The test thread drives
 * them while the driver's device thread calls them: every entry point
 * locks. What the two share (the capture's play, its pace, the injected
 * bytes, the lock) is player.c; what their tests share (the steps every
 * device goes through with a gateway) is devtest.c.
 */
#ifndef AGW_TEST_FAKE_H
#define AGW_TEST_FAKE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* ---- the Razer Hydra (hidapi) ------------------------------------------------------- */

struct fake_hid_stats {
	int enumerations;
	int opens, open_fails, closes;
	int motion_requests;  /* the exact motion-mode feature report, on the control node */
	int gamepad_requests; /* the exact gamepad-mode feature report */
	int other_features;   /* anything else sent as a feature report */
	int wrong_node;	      /* a mode request on another node than interface 1 */
	int get_features;
	uint64_t delivered; /* reports read by the driver */
	int last_index;	    /* capture index of the last report delivered, -1 at first */
};

/* no device, defaults, the capture to play (loaded once) */
void fake_hid_reset(const char *capture);
void fake_hid_plug(bool motion_mode); /* it appears, in the given mode */
void fake_hid_unplug(void);
void fake_hid_ignore_requests(bool on);		      /* it stays in gamepad mode whatever it is told */
void fake_hid_set_mode(bool motion);		      /* the mode changes behind the driver's back */
void fake_hid_deny_open(int err);		      /* hid_open_path fails with errno err (0: opens) */
void fake_hid_period_us(int us);		      /* free-running pace (default 4000) */
void fake_hid_stepped(bool on);			      /* stepped play (see fake_hid_release) */
void fake_hid_release(int n);			      /* stepped: n more reports may be read */
void fake_hid_seek(int index);			      /* the next report is this capture index */
void fake_hid_inject(const uint8_t *rep, size_t len); /* the next read returns these bytes (queued) */
void fake_hid_skip(int n);			      /* n reports are lost: the sequence byte jumps by n + 1 */
void fake_hid_stall(int ms);			      /* no report for ms */
/*
 * The next reports, a letter each: '.' intact, 'J' the left wand 30 m away
 * (an impossible jump), 'Q' the left wand's quaternion zero, 'L' lost (its
 * number skipped, the wands move on), 'S' a 12-byte report (no number)
 * sent before the next one. Then intact again.
 */
void fake_hid_damage(const char *script);
void fake_hid_stats(struct fake_hid_stats *s);
/* the capture's report i (its bytes as recorded, before sequence rewriting) */
const uint8_t *fake_hid_capture_report(int i, size_t *len);
int fake_hid_capture_count(void);

/* ---- the Polhemus Liberty HS (libusb) ---------------------------------------------- */

struct fake_usb_stats {
	int enumerations;
	int opens, closes, claims;
	int hotplug_registered, hotplug_callbacks;
	int clear_halts;
	int zlp;	     /* zero-length OUT packets */
	uint64_t frames;     /* transfers of frames delivered */
	int last_index;	     /* capture index of the last frame delivered */
	char commands[1024]; /* every command received since the last reset, separated by '|' */
	int setups;	     /* C received after a complete set-up */
};

void fake_usb_reset(const char *capture);
void fake_usb_plug(uint16_t pid); /* it appears with this product id (0xff20 ready, 0xff21 before firmware) */
void fake_usb_unplug(void);
void fake_usb_hotplug(bool capable);	 /* LIBUSB_CAP_HAS_HOTPLUG (default yes) */
void fake_usb_deny_open(int libusb_err); /* libusb_open fails with this (0: opens) */
void fake_usb_period_us(int us);	 /* free-running pace (default 1/240 s) */
void fake_usb_stepped(bool on);
void fake_usb_release(int n);
void fake_usb_seek(int index);
void fake_usb_inject(const uint8_t *bytes, size_t len); /* delivered as one transfer before the next frame */
void fake_usb_split(int at);	    /* every frame goes in two transfers, split at byte at (0: off) */
void fake_usb_skip(int n);	    /* n frames lost: the frame count jumps */
void fake_usb_stop_streaming(void); /* it stops sending until it is set up again (P ... C) */
void fake_usb_halt(int times);	    /* the IN endpoint halts (PIPE) and halts again after each clear, times in all */
void fake_usb_stats(struct fake_usb_stats *s);
const uint8_t *fake_usb_capture_frame(int i, size_t *len);
int fake_usb_capture_count(void);

/* ---- allocations on one thread ------------------------------------------------------- */

/* counts malloc/calloc/realloc/free made by the calling thread between start and stop */
void fake_alloc_count_start(void);
long fake_alloc_count_stop(void);

#endif /* AGW_TEST_FAKE_H */
