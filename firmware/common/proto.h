/* The 6-axis controller's serial protocol, version 1 (firmware/PROTOCOL.md is the specification).
 * Frame before stuffing: version, type, seq, payload, CRC-16 (little endian) over the rest;
 * then COBS, then one 0x00 delimiter. Plain C: the firmware and the host tests share it. */
#ifndef FW_PROTO_H
#define FW_PROTO_H

#include <stddef.h>
#include <stdint.h>

#define PROTO_VERSION 1

#define PROTO_HEADER 3 /* version, type, seq */
#define PROTO_CRC 2
#define PROTO_MAX_PAYLOAD 32
#define PROTO_MAX_RAW (PROTO_HEADER + PROTO_MAX_PAYLOAD + PROTO_CRC)
#define PROTO_MAX_ENCODED (PROTO_MAX_RAW + 1) /* COBS adds one byte below 254 */
#define PROTO_MAX_WIRE (PROTO_MAX_ENCODED + 1) /* plus the delimiter */

enum proto_type {
    /* device -> host */
    PROTO_HELLO = 0x01,
    PROTO_HEARTBEAT = 0x02,
    PROTO_AXES = 0x03,
    PROTO_CALIBRATION = 0x04,
    /* host -> device */
    PROTO_HELLO_REQUEST = 0x10,
    PROTO_CALIBRATE = 0x11,
    PROTO_WATCHDOG_TEST = 0x12,
};

#define PROTO_HELLO_LEN 10
#define PROTO_HEARTBEAT_LEN 8
#define PROTO_AXES_LEN 15
#define PROTO_CALIBRATION_LEN 14
#define PROTO_WATCHDOG_KEY "WDT!"
#define PROTO_WATCHDOG_TEST_LEN 4

#define PROTO_AXES_N 6
#define PROTO_AXIS_FULL 32767

/* Reset causes as in the AVR's MCUSR. */
#define PROTO_RESET_POWER_ON 0x01
#define PROTO_RESET_EXTERNAL 0x02
#define PROTO_RESET_BROWN_OUT 0x04
#define PROTO_RESET_WATCHDOG 0x08

enum proto_cal_reason {
    PROTO_CAL_POWER_UP = 0,
    PROTO_CAL_BUTTONS = 1,
    PROTO_CAL_HOST = 2,
};

struct proto_hello {
    uint8_t fw_major, fw_minor, fw_patch;
    uint8_t board;
    uint8_t n_axes, n_buttons;
    uint8_t frame_hz;
    uint16_t heartbeat_ms;
    uint8_t reset_cause;
};

struct proto_heartbeat {
    uint32_t uptime_ms;
    uint16_t rx_ok, rx_rejected;
};

struct proto_axes {
    uint16_t t_ms;
    int16_t axis[PROTO_AXES_N];
    uint8_t buttons;
};

struct proto_calibration {
    uint8_t reason;
    uint8_t eeprom_mask; /* bit i: axis i kept its stored zero */
    uint16_t zero[PROTO_AXES_N]; /* 1/16 ADC counts */
};

/* Payload length of a type, or -1 for a type this version does not know. */
int proto_payload_len(uint8_t type);

/* Payload packers: write exactly PROTO_<TYPE>_LEN bytes, return that length. */
size_t proto_pack_hello(uint8_t *out, const struct proto_hello *m);
size_t proto_pack_heartbeat(uint8_t *out, const struct proto_heartbeat *m);
size_t proto_pack_axes(uint8_t *out, const struct proto_axes *m);
size_t proto_pack_calibration(uint8_t *out, const struct proto_calibration *m);

/* Builds a whole wire frame (COBS and the trailing 0x00) into out, which must hold
 * PROTO_MAX_WIRE bytes. Returns its length, or 0 if len exceeds PROTO_MAX_PAYLOAD. */
size_t proto_frame(uint8_t type, uint8_t seq, const uint8_t *payload, size_t len, uint8_t *out);

enum proto_reject {
    PROTO_OK = 0,
    PROTO_REJ_COBS,
    PROTO_REJ_SHORT,
    PROTO_REJ_CRC,
    PROTO_REJ_VERSION,
    PROTO_REJ_TYPE,
    PROTO_REJ_LENGTH,
    PROTO_REJ_TOO_LONG,
};

/* A validated frame. */
struct proto_msg {
    uint8_t type, seq, len;
    uint8_t payload[PROTO_MAX_PAYLOAD];
};

/* Incremental receiver: fed one byte at a time (from the UART ISR's ring buffer), resyncs at
 * every 0x00. Counting rules match the Python StreamDecoder exactly:
 *   frames_ok      valid frames;
 *   rejected       non-empty chunks between delimiters that are not valid frames;
 *   bytes_skipped  the bytes of those chunks (delimiters and empty chunks are not counted). */
struct proto_rx {
    uint8_t buf[PROTO_MAX_ENCODED];
    uint8_t len;
    uint8_t overflow;       /* chunk outgrew buf: discard until the next delimiter */
    uint32_t overflow_n;    /* bytes dropped in that state */
    uint8_t last_reject;    /* enum proto_reject */
    uint16_t frames_ok, rejected;
    uint32_t bytes_skipped;
};

void proto_rx_init(struct proto_rx *rx);

/* Returns 1 when byte completes a valid frame (stored in *msg), else 0. */
int proto_rx_byte(struct proto_rx *rx, uint8_t byte, struct proto_msg *msg);

/* Validates one chunk (the bytes between two delimiters). Returns PROTO_OK and fills *msg, or
 * the reason for rejecting it. */
enum proto_reject proto_parse(const uint8_t *chunk, size_t len, struct proto_msg *msg);

#endif
