/* The knob box's HID input report (firmware/PROTOCOL.md, "Knob box"): report id 1, seven signed
 * 8-bit detent deltas, one byte of button bits. Plain C. */
#ifndef FW_KNOB_REPORT_H
#define FW_KNOB_REPORT_H

#include <stdint.h>

#define KNOB_N 7
#define KNOB_REPORT_ID 1
#define KNOB_REPORT_SIZE (1 + KNOB_N + 1) /* with the report id byte */

/* Vendor-defined report descriptor, as a byte list so each side places it where it needs it
 * (PROGMEM on the AVR, a plain array on the host). */
#define KNOB_HID_DESCRIPTOR_BYTES                                                   \
    0x06, 0x00, 0xFF,       /* Usage Page (Vendor Defined 0xFF00) */                \
    0x09, 0x01,             /* Usage (0x01: knob box) */                            \
    0xA1, 0x01,             /* Collection (Application) */                          \
    0x85, KNOB_REPORT_ID,   /*   Report ID (1) */                                   \
    0x09, 0x02,             /*   Usage (0x02: detent deltas) */                     \
    0x15, 0x81,             /*   Logical Minimum (-127) */                          \
    0x25, 0x7F,             /*   Logical Maximum (127) */                           \
    0x75, 0x08,             /*   Report Size (8) */                                 \
    0x95, KNOB_N,           /*   Report Count (7) */                                \
    0x81, 0x06,             /*   Input (Data, Variable, Relative) */                \
    0x09, 0x03,             /*   Usage (0x03: push buttons) */                      \
    0x15, 0x00,             /*   Logical Minimum (0) */                             \
    0x25, 0x01,             /*   Logical Maximum (1) */                             \
    0x75, 0x01,             /*   Report Size (1) */                                 \
    0x95, KNOB_N,           /*   Report Count (7) */                                \
    0x81, 0x02,             /*   Input (Data, Variable, Absolute) */                \
    0x95, 0x01,             /*   Report Count (1) */                                \
    0x81, 0x03,             /*   Input (Constant): pad to a whole byte */           \
    0xC0                    /* End Collection */

/* Remembers what the host has been told, so each report carries the change since the last. */
struct knob_report {
    uint8_t sent[KNOB_N]; /* detent counts already reported (mod 256) */
    uint8_t buttons;
};

void knob_report_init(struct knob_report *r, const uint8_t counts[KNOB_N], uint8_t buttons);

/* Builds the next report from the current detent counts (mod 256) and button bits (bit i =
 * knob i+1 pressed). Returns KNOB_REPORT_SIZE if out holds a report worth sending (a delta or a
 * button change, or force), else 0. Counts are compared modulo 256, so the caller must report
 * before any knob moves 128 detents; a delta of -128 goes out as -127 and the rest follows. */
int knob_report_build(struct knob_report *r, const uint8_t counts[KNOB_N], uint8_t buttons,
                      int force, uint8_t out[KNOB_REPORT_SIZE]);

#endif
