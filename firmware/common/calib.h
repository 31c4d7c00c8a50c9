/* Zero-point calibration: the EEPROM record, the power-up choice between measured and stored
 * zeros, and the two-button gesture that stores new zeros. Plain C. */
#ifndef FW_CALIB_H
#define FW_CALIB_H

#include <stdint.h>

#include "proto.h"

#define CALIB_MAGIC0 'Z'
#define CALIB_MAGIC1 '6'
#define CALIB_LAYOUT 1
/* magic (2), layout (1), zeros (6 x u16 LE), CRC-16 over the preceding bytes (LE) */
#define CALIB_RECORD_SIZE (3 + 2 * PROTO_AXES_N + 2)

void calib_pack(const uint16_t zero[PROTO_AXES_N], uint8_t out[CALIB_RECORD_SIZE]);
/* Returns 1 and fills zero[] if the record is intact (magic, layout, CRC, range), else 0:
 * an erased EEPROM (all 0xFF) or a torn write is rejected. */
int calib_unpack(const uint8_t in[CALIB_RECORD_SIZE], uint16_t zero[PROTO_AXES_N]);

/* Power-up choice per axis. The rest position measured at power-up tracks pot drift, so it wins
 * unless it is more than `tolerance` c16 away from the stored zero: then someone is holding the
 * stick while the exhibit boots, and the stored zero is kept. stored == 0 (no valid record)
 * always takes the measurement. Returns the mask of axes that kept the stored zero. */
uint8_t calib_choose(const uint16_t measured[PROTO_AXES_N], const uint16_t *stored,
                     uint16_t tolerance, uint16_t out[PROTO_AXES_N]);

/* Fires once when every button in `mask` has been held for `hold_ticks` consecutive ticks;
 * re-arms only after they are released, so a long hold stores once. */
struct calib_gesture {
    uint16_t held;
    uint8_t fired;
};

void calib_gesture_init(struct calib_gesture *g);
int calib_gesture_step(struct calib_gesture *g, uint8_t buttons, uint8_t mask, uint16_t hold_ticks);

#endif
