/* Knob box wiring on an Arduino Micro (ATmega32U4). Every input is a contact to GND with the
 * internal pull-up; firmware/README.md has the same table for the person with the soldering iron.
 * A and B of each encoder share a port, so one read samples both. */
#ifndef KNOBBOX_PINS_H
#define KNOBBOX_PINS_H

#include <avr/io.h>

#define SCAN_HZ 2000
#define STEPS_PER_DETENT 4  /* EC11-style: one full quadrature cycle per detent */
#define DEBOUNCE_SAMPLES 10 /* 5 ms at 2 kHz */

enum { P_B, P_C, P_D, P_F };

struct knob_pins {
    uint8_t port, a, b;
};
struct button_pin {
    uint8_t port, bit;
};

static const struct knob_pins KNOB_PINS[KNOB_N] = {
    { P_F, _BV(7), _BV(6) }, /* knob 1: A0, A1 */
    { P_F, _BV(5), _BV(4) }, /* knob 2: A2, A3 */
    { P_F, _BV(1), _BV(0) }, /* knob 3: A4, A5 */
    { P_B, _BV(4), _BV(5) }, /* knob 4: D8, D9 */
    { P_B, _BV(6), _BV(7) }, /* knob 5: D10, D11 */
    { P_B, _BV(1), _BV(2) }, /* knob 6: SCK, MOSI */
    { P_D, _BV(1), _BV(0) }, /* knob 7: D2, D3 */
};

static const struct button_pin BUTTON_PINS[KNOB_N] = {
    { P_B, _BV(3) }, /* knob 1 push: MISO */
    { P_D, _BV(2) }, /* knob 2 push: D0 (RX) */
    { P_D, _BV(3) }, /* knob 3 push: D1 (TX) */
    { P_D, _BV(4) }, /* knob 4 push: D4 */
    { P_C, _BV(6) }, /* knob 5 push: D5 */
    { P_D, _BV(7) }, /* knob 6 push: D6 */
    { P_D, _BV(6) }, /* knob 7 push: D12 */
};

/* All of the above as inputs with pull-ups. */
static inline void pins_init(void)
{
    const uint8_t b = 0xFE, c = _BV(6), d = 0xDF, f = 0xF3;
    DDRB &= (uint8_t)~b; PORTB |= b;
    DDRC &= (uint8_t)~c; PORTC |= c;
    DDRD &= (uint8_t)~d; PORTD |= d;
    DDRF &= (uint8_t)~f; PORTF |= f;
}

#endif
