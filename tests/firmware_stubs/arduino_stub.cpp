/* The stub core's main and its mailbox: setup(), then loop() until the simulator has no more
 * codes (GPIOR0: 1 wants a code, 4 an output is in the mailbox, 5 finished). */
#include <avr/interrupt.h>
#include <avr/sleep.h>
#include "Arduino.h"
#include "Wire.h"

struct mailbox {
    uint8_t command;
    uint8_t settled;
    uint8_t spare[2];
    int32_t raw;
    int32_t aux;
    float out;
    uint8_t status;
};

static volatile mailbox box;
SerialStub Serial;
TwoWire Wire;

long stub_next_code(void)
{
    GPIOR0 = 1;
    if (!box.command) {
        GPIOR0 = 5;
        cli();
        sleep_enable();
        sleep_cpu();
        for (;;) {
        }
    }
    return box.raw;
}

void stub_output(float value)
{
    box.out = value;
    box.status = 0;
    GPIOR0 = 4;
}

int main(void)
{
    GPIOR1 = (uint8_t)(uint16_t)&box;
    GPIOR2 = (uint8_t)((uint16_t)&box >> 8);
    setup();
    for (;;)
        loop();
}
