/*
 * A stand-in for Kinova's Gen2 SDK command layer, for the tests only (built at test time with the
 * system's C compiler: cc -shared -fPIC). It exports the functions the driver calls, with the
 * structure layouts of Kinova's public header KinovaTypes.h (declared here from its field lists:
 * float, int and char fields in order, the C++ enums as int), and -DSTANDIN_ETHERNET gives the
 * Ethernet command layer's names (each prefixed Ethernet_).
 *
 * Its arm integrates the angular velocity points it is sent as a Gen2 arm runs them: a FIFO of
 * points, each run for one 10 ms cycle of the arm's controller, the arm still when the FIFO is
 * empty; EraseAllTrajectories empties it. Angles are in degrees (reported in [0, 360)), velocities
 * in degrees per second, fingers in finger units (0 open, 6800 closed). GetAngularVelocity reports
 * the joint velocities times STANDIN_VELOCITY_REPORT (default 0.5: as Gen2 firmware reports them).
 *
 * Read at InitAPI (InitEthernetAPI) from the environment:
 *   STANDIN_LOG      a file each call appends one line to: "<CLOCK_MONOTONIC s> <name> [values]"
 *   STANDIN_DELAY_MS the time each call takes (ms; default 0; read at every call)
 *   STANDIN_DEVICES  the arms GetDevices lists, comma-separated: mico (a 6-joint MICO), jaco7 (a
 *                    7-joint JACO2), jaco6 (a 6-joint JACO2), unfilled (an entry of type 255);
 *                    empty: none (default mico)
 *   STANDIN_START    the six actuator angles at the start (deg, comma-separated; default 0)
 *   STANDIN_FINGERS  the two finger positions at the start (finger units; default 0)
 *   STANDIN_FAIL     NAME:CODE[:N]: the N-th call of NAME (default the first) and every later one
 *                    return CODE
 *   STANDIN_VELOCITY_REPORT  the factor of the reported joint velocities (default 0.5)
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#ifdef STANDIN_ETHERNET
#define API(name) Ethernet_##name
#define PREFIX "Ethernet_"
#else
#define API(name) name
#define PREFIX ""
#endif
#define EXPORT __attribute__((visibility("default")))

enum {
    NO_ERROR_KINOVA = 1,
    ERROR_API_NOT_INITIALIZED = 2101,
    MAX_KINOVA_DEVICE = 20,
    FIFO_SIZE = 2000,
    ANGULAR_VELOCITY = 8,
};
#define CYCLE 0.01      /* s: one point's run */
#define FINGER_CLOSED 6800.0

typedef struct { float Actuator[7]; } AngularInfo;
typedef struct { float Finger[3]; } FingersPosition;
typedef struct { AngularInfo Actuators; FingersPosition Fingers; } AngularPosition;
typedef struct { float X, Y, Z, ThetaX, ThetaY, ThetaZ; } CartesianInfo;
typedef struct {
    int Type;
    float Delay;
    CartesianInfo CartesianPosition;
    AngularInfo Actuators;
    int HandMode;
    FingersPosition Fingers;
} UserPosition;
typedef struct { float Parameter[9]; } Limitation;
typedef struct {
    UserPosition Position;
    int LimitationsActive;
    int SynchroType;
    Limitation Limitations;
} TrajectoryPoint;
typedef struct {
    char SerialNumber[20];
    char Model[20];
    int VersionMajor, VersionMinor, VersionRelease;
    int DeviceType;
    int DeviceID;
} KinovaDevice;
typedef struct {
    unsigned long localIpAddress, subnetMask, robotIpAddress;
    unsigned short localCmdport, localBcastPort, robotPort;
    unsigned long rxTimeOutInMs;
} EthernetCommConfig;

typedef struct { float v[7]; float f[3]; } Point;

static struct {
    int initialized, active, control, angular, joints;
    double q[7], fingers[3];
    Point fifo[FIFO_SIZE];
    int head, count;
    double left;   /* s left of the head point's cycle */
    double cursor; /* time the arm was integrated up to */
    double report;
    char fail_name[64];
    int fail_code;
    long fail_from;
    char names[32][64];
    long calls[32];
    FILE *log;
} S;

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void logf_(const char *format, ...) __attribute__((format(printf, 1, 2)));
static void logf_(const char *format, ...) {
    if (!S.log) return;
    va_list args;
    va_start(args, format);
    fprintf(S.log, "%.6f ", now());
    vfprintf(S.log, format, args);
    fputc('\n', S.log);
    fflush(S.log);
    va_end(args);
}

static void advance(double t) {
    while (S.cursor < t) {
        if (S.count == 0) {
            S.cursor = t;
            return;
        }
        Point *p = &S.fifo[S.head];
        double dt = fmin(S.left, t - S.cursor);
        for (int j = 0; j < S.joints; j++) S.q[j] += p->v[j] * dt;
        for (int k = 0; k < 2; k++) {
            S.fingers[k] = fmin(fmax(S.fingers[k] + p->f[k] * dt, 0.0), FINGER_CLOSED);
        }
        S.left -= dt;
        S.cursor += dt;
        if (S.left <= 1e-12) {
            S.head = (S.head + 1) % FIFO_SIZE;
            S.count--;
            S.left = CYCLE;
        }
    }
}

/* Every call: its time, the arm brought up to now, the configured failure. */
static int begin(const char *name) {
    const char *delay_ms = getenv("STANDIN_DELAY_MS");
    double delay = delay_ms ? atof(delay_ms) / 1000.0 : 0.0;
    if (delay > 0) {
        struct timespec d = {(time_t)delay, (long)((delay - (double)(time_t)delay) * 1e9)};
        nanosleep(&d, NULL);
    }
    advance(now());
    int k = 0;
    while (k < 32 && S.names[k][0] && strcmp(S.names[k], name) != 0) k++;
    if (k == 32) return NO_ERROR_KINOVA;
    if (!S.names[k][0]) snprintf(S.names[k], sizeof S.names[k], "%s", name);
    S.calls[k]++;
    if (S.fail_code && strcmp(S.fail_name, name) == 0 && S.calls[k] >= S.fail_from) {
        logf_("%s%s -> %d", PREFIX, name, S.fail_code);
        return S.fail_code;
    }
    return NO_ERROR_KINOVA;
}

static void parse_list(const char *text, double *out, int n) {
    for (int k = 0; k < n; k++) out[k] = 0.0;
    if (!text) return;
    char *end;
    for (int k = 0; k < n && *text; k++) {
        out[k] = strtod(text, &end);
        text = *end == ',' ? end + 1 : end;
    }
}

static void start(void) {
    if (S.log) fclose(S.log);
    memset(&S, 0, sizeof S);
    const char *path = getenv("STANDIN_LOG");
    S.log = path && *path ? fopen(path, "a") : NULL;
    const char *report = getenv("STANDIN_VELOCITY_REPORT");
    S.report = report ? atof(report) : 0.5;
    parse_list(getenv("STANDIN_START"), S.q, 6);
    parse_list(getenv("STANDIN_FINGERS"), S.fingers, 2);
    const char *fail = getenv("STANDIN_FAIL");
    if (fail && *fail) {
        const char *colon = strchr(fail, ':');
        size_t n = colon ? (size_t)(colon - fail) : strlen(fail);
        if (n >= sizeof S.fail_name) n = sizeof S.fail_name - 1;
        memcpy(S.fail_name, fail, n);
        S.fail_code = colon ? atoi(colon + 1) : 2004;
        const char *second = colon ? strchr(colon + 1, ':') : NULL;
        S.fail_from = second ? atol(second + 1) : 1;
    }
    S.left = CYCLE;
    S.cursor = now();
    S.joints = 6;
    S.initialized = 1;
}

EXPORT int API(InitAPI)(void) {
    start();
    int code = begin("InitAPI");
    logf_(PREFIX "InitAPI");
    return code;
}

#ifdef STANDIN_ETHERNET
static const char *dotted(unsigned long address, char *out) {
    const unsigned char *b = (const unsigned char *)&address; /* network order, as inet_addr */
    sprintf(out, "%u.%u.%u.%u", b[0], b[1], b[2], b[3]);
    return out;
}

EXPORT int API(InitEthernetAPI)(EthernetCommConfig *config) {
    start();
    int code = begin("InitEthernetAPI");
    char a[16], b[16], c[16];
    logf_(PREFIX "InitEthernetAPI local=%s netmask=%s robot=%s ports=%u,%u,%u timeout=%lu",
          dotted(config->localIpAddress, a), dotted(config->subnetMask, b),
          dotted(config->robotIpAddress, c), config->localCmdport, config->localBcastPort,
          config->robotPort, config->rxTimeOutInMs);
    return code;
}
#endif

EXPORT int API(RefresDevicesList)(void) {
    int code = begin("RefresDevicesList");
    logf_(PREFIX "RefresDevicesList");
    return code;
}

EXPORT int API(CloseAPI)(void) {
    int code = begin("CloseAPI");
    logf_(PREFIX "CloseAPI");
    S.initialized = S.active = S.control = S.angular = 0;
    return code;
}

EXPORT int API(GetDevices)(KinovaDevice devices[MAX_KINOVA_DEVICE], int *result) {
    *result = begin("GetDevices");
    if (!S.initialized) *result = ERROR_API_NOT_INITIALIZED;
    const char *list = getenv("STANDIN_DEVICES");
    if (!list) list = "mico";
    int count = 0;
    while (*result == NO_ERROR_KINOVA && *list && count < MAX_KINOVA_DEVICE) {
        KinovaDevice *d = &devices[count];
        memset(d, 0, sizeof *d);
        d->VersionMajor = 6;
        d->VersionMinor = 2;
        d->VersionRelease = 5;
        d->DeviceID = count;
        if (strncmp(list, "mico", 4) == 0) {
            snprintf(d->Model, sizeof d->Model, "MICO");
            d->DeviceType = 1; /* MICO 6-DoF service */
        } else if (strncmp(list, "jaco7", 5) == 0) {
            snprintf(d->Model, sizeof d->Model, "JACO2 7DOF");
            d->DeviceType = 8; /* JACO v2 7-DoF spherical */
        } else if (strncmp(list, "jaco6", 5) == 0) {
            snprintf(d->Model, sizeof d->Model, "JACO2 6DOF");
            d->DeviceType = 3; /* JACO v2 6-DoF service */
        } else {
            d->DeviceType = 255; /* an entry the SDK failed to fill */
        }
        snprintf(d->SerialNumber, sizeof d->SerialNumber, "PJ0000000%d", count + 1);
        count++;
        const char *comma = strchr(list, ',');
        list = comma ? comma + 1 : "";
    }
    logf_(PREFIX "GetDevices count=%d result=%d", count, *result);
    return count;
}

EXPORT int API(SetActiveDevice)(KinovaDevice device) {
    int code = begin("SetActiveDevice");
    logf_(PREFIX "SetActiveDevice serial=%.20s type=%d", device.SerialNumber, device.DeviceType);
    if (code == NO_ERROR_KINOVA) {
        S.active = 1;
        S.joints = device.DeviceType == 8 ? 7 : 6;
    }
    return code;
}

EXPORT int API(StartControlAPI)(void) {
    int code = begin("StartControlAPI");
    logf_(PREFIX "StartControlAPI");
    if (code == NO_ERROR_KINOVA) S.control = 1;
    return code;
}

EXPORT int API(StopControlAPI)(void) {
    int code = begin("StopControlAPI");
    logf_(PREFIX "StopControlAPI");
    S.control = 0;
    return code;
}

EXPORT int API(SetAngularControl)(void) {
    int code = begin("SetAngularControl");
    logf_(PREFIX "SetAngularControl");
    if (code == NO_ERROR_KINOVA) S.angular = 1;
    return code;
}

EXPORT int API(GetAngularPosition)(AngularPosition *out) {
    int code = begin("GetAngularPosition");
    memset(out, 0, sizeof *out);
    for (int j = 0; j < S.joints; j++) {
        double a = fmod(S.q[j], 360.0);
        out->Actuators.Actuator[j] = (float)(a < 0 ? a + 360.0 : a);
    }
    for (int k = 0; k < 2; k++) out->Fingers.Finger[k] = (float)S.fingers[k];
    logf_(PREFIX "GetAngularPosition");
    return code;
}

EXPORT int API(GetAngularVelocity)(AngularPosition *out) {
    int code = begin("GetAngularVelocity");
    memset(out, 0, sizeof *out);
    if (S.count > 0) {
        Point *p = &S.fifo[S.head];
        for (int j = 0; j < S.joints; j++) out->Actuators.Actuator[j] = (float)(p->v[j] * S.report);
        for (int k = 0; k < 2; k++) out->Fingers.Finger[k] = p->f[k];
    }
    logf_(PREFIX "GetAngularVelocity");
    return code;
}

static int send(const char *name, TrajectoryPoint point) {
    int code = begin(name);
    const float *a = point.Position.Actuators.Actuator, *f = point.Position.Fingers.Finger;
    logf_("%s%s type=%d hand=%d limited=%d actuators=%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g "
          "fingers=%.6g,%.6g,%.6g",
          PREFIX, name, point.Position.Type, point.Position.HandMode, point.LimitationsActive,
          a[0], a[1], a[2], a[3], a[4], a[5], a[6], f[0], f[1], f[2]);
    /* An arm runs the API's points once the API controls it in angular mode. */
    if (code != NO_ERROR_KINOVA || !S.control || !S.angular || point.Position.Type != ANGULAR_VELOCITY) {
        return code;
    }
    if (S.count == FIFO_SIZE) return code;
    if (S.count == 0) S.left = CYCLE;
    Point *p = &S.fifo[(S.head + S.count) % FIFO_SIZE];
    for (int j = 0; j < 7; j++) p->v[j] = a[j];
    for (int k = 0; k < 3; k++) p->f[k] = f[k];
    S.count++;
    return code;
}

EXPORT int API(SendAdvanceTrajectory)(TrajectoryPoint point) { return send("SendAdvanceTrajectory", point); }

EXPORT int API(SendBasicTrajectory)(TrajectoryPoint point) { return send("SendBasicTrajectory", point); }

EXPORT int API(EraseAllTrajectories)(void) {
    int code = begin("EraseAllTrajectories");
    logf_(PREFIX "EraseAllTrajectories queued=%d", S.count);
    if (code == NO_ERROR_KINOVA) {
        S.count = 0;
        S.left = CYCLE;
    }
    return code;
}

/* The layouts, for the tests to hold the driver's ctypes declarations to: a structure's size, or a
 * field's offset ("Structure.Field"); -1 for a name not known. */
EXPORT long standin_layout(const char *name) {
#define SIZE(T) if (strcmp(name, #T) == 0) return (long)sizeof(T)
#define AT(T, F, f) if (strcmp(name, #T "." #F) == 0) return (long)offsetof(T, f)
    SIZE(AngularInfo); SIZE(FingersPosition); SIZE(AngularPosition); SIZE(CartesianInfo);
    SIZE(UserPosition); SIZE(Limitation); SIZE(TrajectoryPoint); SIZE(KinovaDevice);
    SIZE(EthernetCommConfig);
    AT(AngularPosition, Fingers, Fingers);
    AT(UserPosition, Delay, Delay); AT(UserPosition, CartesianPosition, CartesianPosition);
    AT(UserPosition, Actuators, Actuators); AT(UserPosition, HandMode, HandMode);
    AT(UserPosition, Fingers, Fingers);
    AT(TrajectoryPoint, LimitationsActive, LimitationsActive);
    AT(TrajectoryPoint, SynchroType, SynchroType); AT(TrajectoryPoint, Limitations, Limitations);
    AT(KinovaDevice, Model, Model); AT(KinovaDevice, VersionMajor, VersionMajor);
    AT(KinovaDevice, DeviceType, DeviceType); AT(KinovaDevice, DeviceID, DeviceID);
    AT(EthernetCommConfig, subnetMask, subnetMask); AT(EthernetCommConfig, robotIpAddress, robotIpAddress);
    AT(EthernetCommConfig, localCmdport, localCmdport); AT(EthernetCommConfig, robotPort, robotPort);
    AT(EthernetCommConfig, rxTimeOutInMs, rxTimeOutInMs);
    return -1;
#undef SIZE
#undef AT
}
