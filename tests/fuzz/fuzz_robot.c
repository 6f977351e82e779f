/* Fuzz target: robot INI files (dm_robot_parse_string, libinih).
 * Property: a robot that parses is written (dm_robot_write) as a file that
 * parses back to the same text (the documented round trip). */
#include "fuzz.h"

#include "dm_robot.h"

static char *write_text(const dm_robot *rb)
{
    char *text = NULL;
    size_t len = 0;
    FILE *mem = open_memstream(&text, &len);
    FUZZ_CHECK(mem, "open_memstream");
    FUZZ_CHECK(dm_robot_write(rb, mem) == DM_OK, "dm_robot_write failed");
    fclose(mem);
    return text;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char *text = fuzz_cstring(data, size);
    if (!text)
        return 0;
    dm_robot rb;
    dm_error err;
    int rc = dm_robot_parse_string(text, "fuzz.ini", &rb, &err);
    FUZZ_CHECK(rc == DM_OK || (rc == DM_EINVAL && !strncmp(err.msg, "fuzz.ini", 8)),
               "error %d without the file's name: %s", rc, err.msg);
    if (rc == DM_OK) {
        char *first = write_text(&rb);
        dm_robot again;
        rc = dm_robot_parse_string(first, "written.ini", &again, &err);
        FUZZ_CHECK(rc == DM_OK, "a parsed robot does not read back: %s\n%s", err.msg, first);
        char *second = write_text(&again);
        FUZZ_CHECK(!strcmp(first, second), "round trip changed the robot:\n%s\n----\n%s", first,
                   second);
        free(first);
        free(second);
    }
    free(text);
    return 0;
}
