# NCCL (optional): the library cuda-bands exchanges halo rows and all-reduces with between GPUs,
# and the probe gpu-peer measures. Found beside the CUDA toolkit (or where NCCL_ROOT says);
# defines the imported target dtflop_nccl and sets DTFLOP_NCCL_FOUND. Used by dtflop's build
# and by find_package(dtflop) (the installed dtflopConfig.cmake), so both find it the same way.
# Linked by its soname (libnccl.so.2): at run time any NCCL 2 the loader finds serves, e.g.
# PyTorch's bundled one through LD_LIBRARY_PATH (scripts/device-bundle.sh).
set(DTFLOP_NCCL_FOUND OFF)
find_path(DTFLOP_NCCL_INCLUDE_DIR nccl.h HINTS ${NCCL_ROOT} $ENV{NCCL_ROOT} ${CUDAToolkit_INCLUDE_DIRS}
          PATH_SUFFIXES include)
find_library(DTFLOP_NCCL_LIBRARY NAMES nccl libnccl.so.2 HINTS ${NCCL_ROOT} $ENV{NCCL_ROOT} ${CUDAToolkit_LIBRARY_DIR}
             PATH_SUFFIXES lib lib64)
if(DTFLOP_NCCL_INCLUDE_DIR AND DTFLOP_NCCL_LIBRARY)
  if(NOT TARGET dtflop_nccl)
    add_library(dtflop_nccl UNKNOWN IMPORTED)
    set_target_properties(dtflop_nccl PROPERTIES IMPORTED_LOCATION "${DTFLOP_NCCL_LIBRARY}"
                                                 INTERFACE_INCLUDE_DIRECTORIES "${DTFLOP_NCCL_INCLUDE_DIR}")
  endif()
  set(DTFLOP_NCCL_FOUND ON)
endif()
