/* dm_version — the tool's version, written into every store it makes. */
#ifndef DM_VERSION_H
#define DM_VERSION_H

#define DM_VERSION "0.5.0"

#endif
