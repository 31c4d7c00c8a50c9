/* Consistent Overhead Byte Stuffing (Cheshire & Baker): removes every 0x00 from a frame so that
 * 0x00 can delimit frames on the wire and a receiver resynchronises at the next 0x00. */
#ifndef FW_COBS_H
#define FW_COBS_H

#include <stddef.h>
#include <stdint.h>

/* Worst-case encoded size of n bytes (without the trailing delimiter). */
#define COBS_MAX_ENCODED(n) ((n) + (n) / 254 + 1)

/* Encodes len bytes from src into dst (room for COBS_MAX_ENCODED(len)); returns encoded length.
 * No delimiter is written. src and dst must not overlap. */
size_t cobs_encode(const uint8_t *src, size_t len, uint8_t *dst);

/* Decodes len bytes (no delimiter) into dst (room for cap bytes). Returns the decoded length,
 * or -1 if the input is not valid COBS (a 0x00 inside, a code running past the end) or does
 * not fit. */
int cobs_decode(const uint8_t *src, size_t len, uint8_t *dst, size_t cap);

#endif
