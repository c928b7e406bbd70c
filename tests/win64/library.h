/* What the two test drivers (driver.c for FMI 2.0, driver3.c for FMI 3.0) share: loading a
 * shared library the same way on Linux (dlopen) and Windows (LoadLibrary), looking up a
 * function with a message if it is missing, and reading VR=VALUE arguments. */
#ifndef PENDFMU_TEST_LIBRARY_H
#define PENDFMU_TEST_LIBRARY_H

#include <stdlib.h>
#include <string.h>

#ifdef _WIN32
#include <windows.h>
typedef HMODULE Library;
static Library open_library(const char *path) { return LoadLibraryA(path); }
static void (*symbol(Library library, const char *name))(void) {
    return (void (*)(void))GetProcAddress(library, name);
}
#else
#include <dlfcn.h>
typedef void *Library;
static Library open_library(const char *path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
static void (*symbol(Library library, const char *name))(void) {
    void *address = dlsym(library, name);
    void (*function)(void);
    memcpy(&function, &address, sizeof function); /* POSIX: data and function pointers agree */
    return function;
}
#endif

#define MAX_VARIABLES 32
/* `name` from the library opened from argv[1], or exit status 2 with a message. */
#define LOAD(name)                                                                \
    name##TYPE *name = (name##TYPE *)symbol(library, #name);                      \
    if (!name) {                                                                  \
        fprintf(stderr, "%s does not export %s\n", argv[1], #name);               \
        return 2;                                                                 \
    }

/* "VR=VALUE" into its value reference and value; 0 if the text is not of that form. */
static int parse_assignment(const char *text, unsigned *vr, double *value) {
    char *end;
    *vr = (unsigned)strtoul(text, &end, 10);
    if (*end != '=') return 0;
    *value = strtod(end + 1, &end);
    return *end == 0;
}

#endif
