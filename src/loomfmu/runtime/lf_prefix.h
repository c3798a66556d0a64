/* loomfmu shared runtime: names of the runtime's global symbols.
 *
 * In an FMU, loomfmu.export.codegen replaces this file with one that renames every
 * global symbol of the runtime to <modelIdentifier>_lf_..., so that the
 * sources of several loomfmu FMUs can be linked into one program.  This
 * default keeps the plain names (for the runtime's own C tests). */
#ifndef LF_PREFIX_H
#define LF_PREFIX_H
#endif
