/* File URIs to local paths, for the resource location an importer passes to fmi2Instantiate.
 *
 * Kept apart from the rest of the framework (no variables.h) so that a tiny test program
 * can check it directly, built natively and for Windows (tests/win64/uri_test.c).
 */
#ifndef PENDFMU_URI_H
#define PENDFMU_URI_H

#include <stdbool.h>
#include <stddef.h>

typedef enum {
    PATHS_POSIX,  /* "/dir/res" */
    PATHS_WINDOWS /* "C:\dir\res", "\\server\share\dir" */
} PathStyle;

/* The style of the platform the file is compiled for, and its directory separator. */
#ifdef _WIN32
#define LOCAL_PATHS PATHS_WINDOWS
#define LOCAL_PATH_SEPARATOR "\\"
#else
#define LOCAL_PATHS PATHS_POSIX
#define LOCAL_PATH_SEPARATOR "/"
#endif

/* The local path, in `style`, of a file URI: "file:///C:/dir", "file:/dir",
 * "file://localhost/dir" or, on Windows, the share "file://server/share/dir". Percent
 * escapes are decoded. False, with `path` unspecified, for anything else: another scheme,
 * a relative path, a malformed escape ("%2" at the end, "%zz"), an escaped NUL, a host
 * other than localhost on POSIX, or a path longer than `size` - 1 characters. */
bool file_uri_to_path(const char *uri, PathStyle style, char *path, size_t size);

#endif
