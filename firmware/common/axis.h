/* Analog axis conditioning: low-pass filter, zero point, dead zone, scaling to +-32767.
 * Units: "c16" = 1/16 of an ADC count (0..16368 for a 10-bit ADC), so four summed
 * oversamples times four carry fraction bits through the filter. Plain C. */
#ifndef FW_AXIS_H
#define FW_AXIS_H

#include <stdint.h>

#define AXIS_C16_MAX (1023 * 16)

/* First-order IIR low pass, y += (x - y) / 2^shift, state kept with 4 more fraction bits. */
struct axis_filter {
    int32_t state; /* c16 << 4 */
    uint8_t shift;
    uint8_t primed;
};

void axis_filter_init(struct axis_filter *f, uint8_t shift);
/* Feeds one sample (c16); returns the filtered value (c16). The first sample primes the state
 * so the output does not ramp up from zero after reset. */
uint16_t axis_filter_step(struct axis_filter *f, uint16_t x);

struct axis_cfg {
    uint16_t deadzone; /* c16 either side of zero that reads as 0 */
    uint16_t edge;     /* c16 short of each rail that already reads full scale */
};

/* Maps a filtered reading to -32767..32767: 0 inside the dead zone, rising linearly from the
 * dead-zone edge (no jump) to full scale at `edge` short of the rail on that side. The two
 * sides are scaled separately because the zero is rarely at mid-scale. */
int16_t axis_scale(uint16_t value, uint16_t zero, const struct axis_cfg *cfg);

#endif
