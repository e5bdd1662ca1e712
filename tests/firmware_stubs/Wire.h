/* A stub of Arduino's Wire (I2C) library: nothing is on the bus. */
#ifndef WIRE_STUB_H
#define WIRE_STUB_H
class TwoWire {
public:
    void begin() {}
};
extern TwoWire Wire;
#endif
