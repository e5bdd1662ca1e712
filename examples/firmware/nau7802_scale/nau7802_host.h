/* nau7802_host.h: a simulated NAU7802 on a simulated I2C bus, for running the sketch on a host.
 * Not for the target. */
#ifndef NAU7802_HOST_H
#define NAU7802_HOST_H
#include <stdint.h>

void host_i2c_write(uint8_t address, uint8_t reg, uint8_t value);
void host_i2c_read(uint8_t address, uint8_t reg, uint8_t *out, int n);
/* Prints "raw<TAB>temperature<TAB>corrected" on standard output. */
void host_report_temperature(int32_t raw, float temperature_c, float corrected);

/* The sketch's entry points. */
void setup(void);
void loop(void);
#endif
