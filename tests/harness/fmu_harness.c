/*
 * fmu_harness: load FMI 2.0 Co-Simulation libraries the way an importer does and run them.
 *
 * Built with each target's C compiler (gcc, x86_64-w64-mingw32-gcc, aarch64-linux-gnu-gcc) and
 * run natively, under wine and under qemu-aarch64 by tests/python/test_platforms.py, which
 * compares the platforms' results. It loads each library with LoadLibrary/dlopen, resolves all
 * 44 fmi2 functions (Model Exchange's too), hands the FMU its resource URI in the platform's form, and checks the
 * calls an importer relies on: a wrong GUID is refused, every call of the run returns fmi2OK,
 * and a panic inside the FMU comes back as fmi2Error with a log message.
 *
 *   fmu_harness run PLAN OUT.csv
 *   fmu_harness panic LIBRARY GUID VR
 *
 * PLAN is a tab-separated text file (written by the test from an OSP system structure):
 *   fmu      NAME LIBRARY RESOURCE_URI GUID     one line per FMU, stepped in this order
 *   real     FMU VR VALUE                       a start value (FMU = index of its fmu line)
 *   integer  FMU VR VALUE
 *   connect  FROM VR TO VR                      a Real output to a Real input, set before TO steps
 *   record   FMU VR COLUMN                      a Real written to OUT.csv at every step
 *   time     STEP STOP
 * `panic` sets the Real VR to 666 (the probe FMU panics on it), steps, and expects fmi2Error, an
 * "internal error" log message and a working fmi2Reset.
 *
 * The FMI 2.0 types are declared here rather than taken from the standard's headers: only the
 * handful below cross the ABI, and the harness then builds with nothing but a C compiler.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _WIN32
#include <windows.h>
typedef HMODULE Library;
static Library open_library(const char *path) { return LoadLibraryA(path); }
static void *symbol(Library l, const char *name) { return (void *)GetProcAddress(l, name); }
static void close_library(Library l) { FreeLibrary(l); }
static const char *load_error(void) {
    static char buf[64];
    snprintf(buf, sizeof buf, "LoadLibrary error %lu", (unsigned long)GetLastError());
    return buf;
}
#else
#include <dlfcn.h>
typedef void *Library;
static Library open_library(const char *path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
static void *symbol(Library l, const char *name) { return dlsym(l, name); }
static void close_library(Library l) { dlclose(l); }
static const char *load_error(void) { return dlerror(); }
#endif

typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef int fmi2Status; /* fmi2OK 0, Warning 1, Discard 2, Error 3, Fatal 4, Pending 5 */
enum { fmi2OK = 0, fmi2Error = 3 };

typedef struct {
    void (*logger)(fmi2ComponentEnvironment, const char *, fmi2Status, const char *, const char *, ...);
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(fmi2ComponentEnvironment, fmi2Status);
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

typedef fmi2Component (*Instantiate)(const char *, int, const char *, const char *,
                                     const fmi2CallbackFunctions *, fmi2Boolean, fmi2Boolean);
typedef void (*FreeInstance)(fmi2Component);
typedef fmi2Status (*SetupExperiment)(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real, fmi2Boolean, fmi2Real);
typedef fmi2Status (*Simple)(fmi2Component);
typedef fmi2Status (*RealIO)(fmi2Component, const fmi2ValueReference *, size_t, fmi2Real *);
typedef fmi2Status (*IntegerIO)(fmi2Component, const fmi2ValueReference *, size_t, fmi2Integer *);
typedef fmi2Status (*DoStep)(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean);

/* The 44 functions of FMI 2.0, common, Co-Simulation and Model Exchange: every one must
 * resolve (an importer may resolve them all whichever interface it uses). */
static const char *const FUNCTIONS[44] = {
    "fmi2GetTypesPlatform", "fmi2GetVersion", "fmi2SetDebugLogging", "fmi2Instantiate",
    "fmi2FreeInstance", "fmi2SetupExperiment", "fmi2EnterInitializationMode",
    "fmi2ExitInitializationMode", "fmi2Terminate", "fmi2Reset", "fmi2GetReal", "fmi2GetInteger",
    "fmi2GetBoolean", "fmi2GetString", "fmi2SetReal", "fmi2SetInteger", "fmi2SetBoolean",
    "fmi2SetString", "fmi2GetFMUstate", "fmi2SetFMUstate", "fmi2FreeFMUstate",
    "fmi2SerializedFMUstateSize", "fmi2SerializeFMUstate", "fmi2DeSerializeFMUstate",
    "fmi2GetDirectionalDerivative", "fmi2SetRealInputDerivatives",
    "fmi2GetRealOutputDerivatives", "fmi2DoStep", "fmi2CancelStep", "fmi2GetStatus",
    "fmi2GetRealStatus", "fmi2GetIntegerStatus", "fmi2GetBooleanStatus", "fmi2GetStringStatus",
    "fmi2EnterEventMode", "fmi2NewDiscreteStates", "fmi2EnterContinuousTimeMode",
    "fmi2CompletedIntegratorStep", "fmi2SetTime", "fmi2SetContinuousStates", "fmi2GetDerivatives",
    "fmi2GetEventIndicators", "fmi2GetContinuousStates", "fmi2GetNominalsOfContinuousStates",
};

typedef struct {
    char *name;
    Library lib;
    fmi2Component c;
    Instantiate instantiate;
    FreeInstance free_instance;
    SetupExperiment setup;
    Simple enter_init, exit_init, terminate, reset;
    RealIO get_real, set_real;
    IntegerIO set_integer;
    DoStep do_step;
} Fmu;

static char last_message[4096];

static void logger(fmi2ComponentEnvironment env, const char *instance, fmi2Status status,
                   const char *category, const char *format, ...) {
    va_list args;
    (void)env;
    va_start(args, format);
    vsnprintf(last_message, sizeof last_message, format, args);
    va_end(args);
    fprintf(stderr, "[%s %s status %d] %s\n", instance ? instance : "?", category ? category : "",
            status, last_message);
}

static const fmi2CallbackFunctions CALLBACKS = {logger, calloc, free, NULL, NULL};

static void die(const char *what, const char *detail) {
    fprintf(stderr, "fmu_harness: %s%s%s\n", what, detail ? ": " : "", detail ? detail : "");
    exit(1);
}

static void check(fmi2Status status, const Fmu *f, const char *call) {
    if (status != fmi2OK) {
        fprintf(stderr, "fmu_harness: %s of %s returned status %d\n", call, f->name, status);
        exit(1);
    }
}

static void load(Fmu *f, const char *name, const char *path) {
    int i;
    f->name = strdup(name);
    f->lib = open_library(path);
    if (!f->lib) die(path, load_error());
    for (i = 0; i < 44; i++)
        if (!symbol(f->lib, FUNCTIONS[i])) die(FUNCTIONS[i], "not exported");
    f->instantiate = (Instantiate)symbol(f->lib, "fmi2Instantiate");
    f->free_instance = (FreeInstance)symbol(f->lib, "fmi2FreeInstance");
    f->setup = (SetupExperiment)symbol(f->lib, "fmi2SetupExperiment");
    f->enter_init = (Simple)symbol(f->lib, "fmi2EnterInitializationMode");
    f->exit_init = (Simple)symbol(f->lib, "fmi2ExitInitializationMode");
    f->terminate = (Simple)symbol(f->lib, "fmi2Terminate");
    f->reset = (Simple)symbol(f->lib, "fmi2Reset");
    f->get_real = (RealIO)symbol(f->lib, "fmi2GetReal");
    f->set_real = (RealIO)symbol(f->lib, "fmi2SetReal");
    f->set_integer = (IntegerIO)symbol(f->lib, "fmi2SetInteger");
    f->do_step = (DoStep)symbol(f->lib, "fmi2DoStep");
}

/* Instantiate, after checking that a wrong GUID is refused. */
static void instantiate(Fmu *f, const char *uri, const char *guid) {
    const char *resources = uri[0] ? uri : NULL;
    if (f->instantiate(f->name, 1, "{not-the-guid}", resources, &CALLBACKS, 0, 0))
        die(f->name, "accepted a wrong GUID");
    f->c = f->instantiate(f->name, 1, guid, resources, &CALLBACKS, 0, 0);
    if (!f->c) die(f->name, "fmi2Instantiate returned NULL (see the log above)");
}

/* Split a line at tabs in place; returns the number of fields. */
static int fields(char *line, char **out, int max) {
    int n = 0;
    char *p = line;
    line[strcspn(line, "\r\n")] = 0;
    while (n < max) {
        out[n++] = p;
        p = strchr(p, '\t');
        if (!p) break;
        *p++ = 0;
    }
    return n;
}

enum { MAX_FMUS = 8, MAX_ITEMS = 256 };
typedef struct { int fmu; fmi2ValueReference vr; double value; int integer; } Start;
typedef struct { int from; fmi2ValueReference from_vr; int to; fmi2ValueReference to_vr; } Connection;
typedef struct { int fmu; fmi2ValueReference vr; char *column; } Record;

static int index_of(const char *s, int n) {
    int i = atoi(s);
    if (i < 0 || i >= n) die("plan names an FMU that has no fmu line", s);
    return i;
}

static int run(const char *plan_path, const char *out_path) {
    static Fmu fmus[MAX_FMUS];
    static char *uris[MAX_FMUS], *guids[MAX_FMUS];
    static Start starts[MAX_ITEMS];
    static Connection connections[MAX_ITEMS];
    static Record records[MAX_ITEMS];
    int n_fmus = 0, n_starts = 0, n_connections = 0, n_records = 0, i, j;
    double step = 0, stop = 0;
    long k, steps;
    char line[8192], *f[8];
    FILE *plan = fopen(plan_path, "r"), *out;
    if (!plan) die("cannot open the plan", plan_path);
    while (fgets(line, sizeof line, plan)) {
        int n = fields(line, f, 8);
        if (!strcmp(f[0], "fmu") && n == 5 && n_fmus < MAX_FMUS) {
            load(&fmus[n_fmus], f[1], f[2]);
            uris[n_fmus] = strdup(f[3]);
            guids[n_fmus] = strdup(f[4]);
            n_fmus++;
        } else if ((!strcmp(f[0], "real") || !strcmp(f[0], "integer")) && n == 4 && n_starts < MAX_ITEMS) {
            Start s = {index_of(f[1], n_fmus), (fmi2ValueReference)strtoul(f[2], NULL, 10),
                       strtod(f[3], NULL), !strcmp(f[0], "integer")};
            starts[n_starts++] = s;
        } else if (!strcmp(f[0], "connect") && n == 5 && n_connections < MAX_ITEMS) {
            Connection c = {index_of(f[1], n_fmus), (fmi2ValueReference)strtoul(f[2], NULL, 10),
                            index_of(f[3], n_fmus), (fmi2ValueReference)strtoul(f[4], NULL, 10)};
            connections[n_connections++] = c;
        } else if (!strcmp(f[0], "record") && n == 4 && n_records < MAX_ITEMS) {
            Record r = {index_of(f[1], n_fmus), (fmi2ValueReference)strtoul(f[2], NULL, 10), strdup(f[3])};
            records[n_records++] = r;
        } else if (!strcmp(f[0], "time") && n == 3) {
            step = strtod(f[1], NULL);
            stop = strtod(f[2], NULL);
        } else if (f[0][0]) {
            die("unreadable plan line", f[0]);
        }
    }
    fclose(plan);
    if (n_fmus == 0 || step <= 0 || stop <= 0) die("the plan needs fmu lines and a time line", NULL);

    for (i = 0; i < n_fmus; i++) {
        Fmu *m = &fmus[i];
        instantiate(m, uris[i], guids[i]);
        check(m->setup(m->c, 0, 0.0, 0.0, 1, stop), m, "fmi2SetupExperiment");
        for (j = 0; j < n_starts; j++) {
            if (starts[j].fmu != i) continue;
            if (starts[j].integer) {
                fmi2Integer v = (fmi2Integer)starts[j].value;
                check(m->set_integer(m->c, &starts[j].vr, 1, &v), m, "fmi2SetInteger");
            } else {
                check(m->set_real(m->c, &starts[j].vr, 1, &starts[j].value), m, "fmi2SetReal");
            }
        }
        check(m->enter_init(m->c), m, "fmi2EnterInitializationMode");
        check(m->exit_init(m->c), m, "fmi2ExitInitializationMode");
    }

    out = fopen(out_path, "w");
    if (!out) die("cannot write", out_path);
    fprintf(out, "time");
    for (j = 0; j < n_records; j++) fprintf(out, ",%s", records[j].column);
    fprintf(out, "\n");
    /* Gauss-Seidel: before an FMU steps, its inputs take the current outputs of its sources. */
    steps = (long)(stop / step + 0.5);
    for (k = 0; k < steps; k++) {
        double t = k * step;
        for (i = 0; i < n_fmus; i++) {
            for (j = 0; j < n_connections; j++) {
                Connection *c = &connections[j];
                fmi2Real v;
                if (c->to != i) continue;
                check(fmus[c->from].get_real(fmus[c->from].c, &c->from_vr, 1, &v), &fmus[c->from], "fmi2GetReal");
                check(fmus[i].set_real(fmus[i].c, &c->to_vr, 1, &v), &fmus[i], "fmi2SetReal");
            }
            check(fmus[i].do_step(fmus[i].c, t, step, 1), &fmus[i], "fmi2DoStep");
        }
        fprintf(out, "%.17g", (k + 1) * step);
        for (j = 0; j < n_records; j++) {
            fmi2Real v;
            check(fmus[records[j].fmu].get_real(fmus[records[j].fmu].c, &records[j].vr, 1, &v),
                  &fmus[records[j].fmu], "fmi2GetReal");
            fprintf(out, ",%.17g", v);
        }
        fprintf(out, "\n");
    }
    fclose(out);
    for (i = 0; i < n_fmus; i++) {
        check(fmus[i].terminate(fmus[i].c), &fmus[i], "fmi2Terminate");
        fmus[i].free_instance(fmus[i].c);
        close_library(fmus[i].lib);
    }
    printf("fmu_harness: %d FMUs, %ld steps, %d columns -> %s\n", n_fmus, steps, n_records, out_path);
    return 0;
}

static int panic_probe(const char *library, const char *guid, const char *vr_text) {
    Fmu m;
    fmi2ValueReference vr = (fmi2ValueReference)strtoul(vr_text, NULL, 10);
    fmi2Real beast = 666.0;
    fmi2Status status;
    load(&m, "probe", library);
    instantiate(&m, "", guid);
    check(m.setup(m.c, 0, 0.0, 0.0, 0, 0.0), &m, "fmi2SetupExperiment");
    check(m.enter_init(m.c), &m, "fmi2EnterInitializationMode");
    check(m.exit_init(m.c), &m, "fmi2ExitInitializationMode");
    check(m.set_real(m.c, &vr, 1, &beast), &m, "fmi2SetReal");
    last_message[0] = 0;
    status = m.do_step(m.c, 0.0, 0.1, 1);
    if (status != fmi2Error) {
        fprintf(stderr, "fmu_harness: the panicking fmi2DoStep returned %d, not fmi2Error\n", status);
        return 1;
    }
    if (!strstr(last_message, "internal error")) die("no 'internal error' log message after the panic", last_message);
    check(m.reset(m.c), &m, "fmi2Reset after the panic");
    m.free_instance(m.c);
    close_library(m.lib);
    printf("fmu_harness: panic -> fmi2Error, logged \"%s\", reset OK\n", last_message);
    return 0;
}

int main(int argc, char **argv) {
    if (argc == 4 && !strcmp(argv[1], "run")) return run(argv[2], argv[3]);
    if (argc == 5 && !strcmp(argv[1], "panic")) return panic_probe(argv[2], argv[3], argv[4]);
    fprintf(stderr, "usage: fmu_harness run PLAN OUT.csv | fmu_harness panic LIBRARY GUID VR\n");
    return 2;
}
