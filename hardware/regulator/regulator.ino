// bendscope pressure regulator: an Arduino (Uno, Nano, Leonardo) between the host and a
// proportional pressure regulator (e.g. SMC ITV0030, Festo VPPM: 0-10 V command).
//
// Host line protocol (115200 baud, 8N1, lines end in \n; \r is ignored):
//   SET <kPa>   ->  OK <kPa>      new set point (0 .. REG_MAX_KPA), echoed
//   GET         ->  P <kPa>       measured pressure (mean of SAMPLES analog readings)
//   anything    ->  ERR <text>    out of range, sensor fault, unknown command
// At power-up (and when the host opens the port, which resets the board) the output is
// 0 kPa. If the host sends nothing for HOST_TIMEOUT_MS, the regulator is vented: a host
// that crashed does not leave the actuator under pressure (bendscope talks at least
// once a second).
//
// Wiring (see README, section acquire):
//   pin 9 (PWM, 31 kHz) -> RC low-pass 1 kOhm / 10 uF -> op-amp (LM358 on 12 V),
//                          non-inverting gain 2 -> regulator command input (0-10 V)
//   A0 <- pressure sensor output (e.g. MPX5700DP: 0.2 V at 0 kPa .. 4.7 V at 700 kPa),
//         or the regulator's monitor output scaled to 0-5 V
//   GND common to the Arduino, the op-amp, the regulator's 0 V and the sensor.

const long BAUD = 115200;
const int PWM_PIN = 9;
const int SENSOR_PIN = A0;

// The regulator: command 0..CMD_FULL_V (after the op-amp) gives 0..REG_MAX_KPA.
const float REG_MAX_KPA = 100.0;
// The sensor: SENSOR_V0 volts at 0 kPa, SENSOR_KPA_PER_V kPa per volt above it.
const float SENSOR_V0 = 0.2;
const float SENSOR_KPA_PER_V = 700.0 / 4.5;
// A sensor reading below this voltage means a broken wire.
const float SENSOR_MIN_V = 0.05;
const float ADC_REF_V = 5.0;
const int SAMPLES = 16;
const unsigned long HOST_TIMEOUT_MS = 120000UL;

float setPointKpa = 0.0;
unsigned long lastCommandMs = 0;
char line[48];
byte lineLen = 0;

void writeSetPoint(float kpa) {
  // 8-bit PWM duty in proportion to the set point; the op-amp scales 0-5 V to 0-10 V.
  int duty = (int)(255.0 * kpa / REG_MAX_KPA + 0.5);
  analogWrite(PWM_PIN, constrain(duty, 0, 255));
  setPointKpa = kpa;
}

// Measured pressure, kPa; negative when the sensor is disconnected.
float readPressureKpa() {
  long sum = 0;
  for (int i = 0; i < SAMPLES; i++) sum += analogRead(SENSOR_PIN);
  float volts = ADC_REF_V * (sum / (float)SAMPLES) / 1023.0;
  if (volts < SENSOR_MIN_V) return -1.0;
  float kpa = (volts - SENSOR_V0) * SENSOR_KPA_PER_V;
  return kpa < 0.0 ? 0.0 : kpa;
}

void handle(char *cmd) {
  if (strncmp(cmd, "SET ", 4) == 0) {
    char *end;
    float kpa = strtod(cmd + 4, &end);
    if (end == cmd + 4) {
      Serial.println(F("ERR SET needs a number in kPa"));
    } else if (kpa < 0.0 || kpa > REG_MAX_KPA) {
      Serial.print(F("ERR out of range 0.."));
      Serial.print(REG_MAX_KPA, 2);
      Serial.println(F(" kPa"));
    } else {
      writeSetPoint(kpa);
      Serial.print(F("OK "));
      Serial.println(kpa, 2);
    }
  } else if (strcmp(cmd, "GET") == 0) {
    float p = readPressureKpa();
    if (p < 0.0) {
      Serial.println(F("ERR sensor fault: no signal on A0"));
    } else {
      Serial.print(F("P "));
      Serial.println(p, 3);
    }
  } else {
    Serial.println(F("ERR unknown command (SET <kPa> or GET)"));
  }
}

void setup() {
#if defined(TCCR1B)
  // Timer 1 (pins 9, 10) at 31 kHz: a ripple the RC filter removes.
  TCCR1B = (TCCR1B & 0b11111000) | 0x01;
#endif
  pinMode(PWM_PIN, OUTPUT);
  writeSetPoint(0.0);
  Serial.begin(BAUD);
  lastCommandMs = millis();
}

void loop() {
  while (Serial.available() > 0) {
    char c = Serial.read();
    if (c == '\r') continue;
    if (c == '\n') {
      line[lineLen] = '\0';
      if (lineLen > 0) handle(line);
      lineLen = 0;
      lastCommandMs = millis();
    } else if (lineLen < sizeof(line) - 1) {
      line[lineLen++] = c;
    }
  }
  if (setPointKpa > 0.0 && millis() - lastCommandMs > HOST_TIMEOUT_MS) {
    writeSetPoint(0.0);  // the host is gone: vent
  }
}
