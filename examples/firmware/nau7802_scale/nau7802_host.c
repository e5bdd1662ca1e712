/* nau7802_host.c: runs the sketch on a host. Each line of standard input is one sample period:
 * the bridge's signed 24-bit code and the chip's temperature (°C). The simulated chip answers
 * register reads: a conversion is always ready; the result registers hold the bridge code, or
 * with the TS bit of I2C_CONTROL set the internal sensor's code for that temperature (109 mV
 * at 25 °C, 360 uV/K, gain 1, full scale +-1.65 V = 2^23). main() calls setup() and then loop()
 * once per line. */
#include <stdio.h>
#include "nau7802_host.h"

static uint8_t i2c_control;
static long bridge_code;
static float chip_temperature = 20.0f;

static long temperature_code(void)
{
    const double volts = 0.109 + 360e-6 * ((double)chip_temperature - 25.0);
    return (long)(volts / 1.65 * 8388608.0 + 0.5);
}

void host_i2c_write(uint8_t address, uint8_t reg, uint8_t value)
{
    if (address == 0x2A && reg == 0x11)
        i2c_control = value;
}

void host_i2c_read(uint8_t address, uint8_t reg, uint8_t *out, int n)
{
    const long code = (i2c_control & 0x02) ? temperature_code() : bridge_code;
    const uint32_t word = (uint32_t)code & 0xffffffUL;
    int i;
    for (i = 0; i < n; ++i, ++reg) {
        if (address != 0x2A)
            out[i] = 0xff;
        else if (reg == 0x00)
            out[i] = 0x20 | 0x0e;           /* CR: ready; powered up */
        else if (reg == 0x11)
            out[i] = i2c_control;
        else if (reg >= 0x12 && reg <= 0x14)
            out[i] = (uint8_t)(word >> (8 * (0x14 - reg)));
        else
            out[i] = 0;
    }
}

void host_report_temperature(int32_t raw, float temperature_c, float corrected)
{
    printf("%ld\t%.9g\t%.9g\n", (long)raw, (double)temperature_c, (double)corrected);
}

int main(void)
{
    char line[128];
    int first = 1;
    while (fgets(line, sizeof line, stdin) != NULL) {
        if (sscanf(line, "%ld %f", &bridge_code, &chip_temperature) != 2)
            continue;
        if (bridge_code < -8388608L || bridge_code > 8388607L) {
            fprintf(stderr, "code %ld is outside the NAU7802's 24 bits\n", bridge_code);
            return 2;
        }
        if (first) {
            setup();
            first = 0;
        }
        loop();
    }
    return 0;
}
