/* hx711_host.c: runs the sketch on a host. The simulated HX711 takes its conversions from
 * standard input (signed 24-bit codes, one per line, optionally followed by the sensor's
 * temperature in °C) and shifts each out bit by bit on the clock edges, as the chip does;
 * main() calls setup() and then loop() once per code. */
#include <stdio.h>
#include <stdlib.h>
#include "hx711_host.h"

static uint32_t shift_register;   /* bits of the conversion being read, MSB first */
static int bits_left;              /* 0: no conversion pending (DOUT high) */
static int clock_level;
static int dout_level = HIGH;
static float temperature_c = 20.0f;

void pinMode(int pin, int mode) { (void)pin; (void)mode; }
void delayMicroseconds(unsigned int us) { (void)us; }

int digitalRead(int pin)
{
    (void)pin;
    return dout_level;
}

void digitalWrite(int pin, int value)
{
    (void)pin;
    if (value == HIGH && clock_level == LOW && bits_left > 0) {   /* rising edge: next bit */
        --bits_left;
        dout_level = bits_left >= 1 ? (int)((shift_register >> (bits_left - 1)) & 1u) : HIGH;
    }
    clock_level = value;
}

void host_report(int32_t raw, int32_t corrected_word)
{
    printf("%ld\t%ld\n", (long)raw, (long)corrected_word);
}

void host_report_temperature(int32_t raw, float temperature, float corrected)
{
    printf("%ld\t%.9g\t%.9g\n", (long)raw, (double)temperature, (double)corrected);
}

float host_temperature_c(void)
{
    return temperature_c;
}

int main(void)
{
    char line[128];
    long code;
    setup();
    while (fgets(line, sizeof line, stdin) != NULL) {
        if (sscanf(line, "%ld %f", &code, &temperature_c) < 1)
            continue;
        if (code < -8388608L || code > 8388607L) {
            fprintf(stderr, "code %ld is outside the HX711's 24 bits\n", code);
            return 2;
        }
        shift_register = (uint32_t)code & 0xffffffUL;
        bits_left = 25;       /* 24 data bits and the gain pulse */
        dout_level = LOW;     /* conversion ready */
        loop();
    }
    return 0;
}
