// dtflop-pingpong: the MPI ping-pong that probe_net_mpi.cpp runs as `mpirun -n 2 dtflop-pingpong
// REPS SIZE...`. Rank 0 sends SIZE bytes to rank 1, which sends them back, REPS times per size
// after one untimed round; rank 0 prints one line per size: the size, then each round trip's
// half, in seconds. Each round checks the payload came back intact.
#include <mpi.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  if (size != 2 || argc < 3) {
    if (rank == 0) std::fprintf(stderr, "dtflop-pingpong: run as `mpirun -n 2 dtflop-pingpong REPS SIZE...`\n");
    MPI_Finalize();
    return 2;
  }
  const int reps = std::atoi(argv[1]);
  int status = 0;
  for (int a = 2; a < argc; ++a) {
    const long bytes = std::atol(argv[a]);
    if (reps < 1 || reps > 100000 || bytes < 1 || bytes > (1L << 30)) {
      status = 2;
      break;
    }
    std::vector<unsigned char> buf(static_cast<std::size_t>(bytes));
    std::vector<double> half;
    for (int r = -1; r < reps; ++r) {
      const unsigned char mark = static_cast<unsigned char>(r + 2);
      if (rank == 0) {
        buf.front() = mark, buf.back() = mark;
        const double t0 = MPI_Wtime();
        MPI_Send(buf.data(), static_cast<int>(bytes), MPI_BYTE, 1, a, MPI_COMM_WORLD);
        MPI_Recv(buf.data(), static_cast<int>(bytes), MPI_BYTE, 1, a, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        const double t = MPI_Wtime() - t0;
        if (buf.front() != static_cast<unsigned char>(mark + 1) || buf.back() != static_cast<unsigned char>(mark + 1))
          status = 1;  // the echo did not come back as sent
        if (r >= 0) half.push_back(t / 2);
      } else {
        MPI_Recv(buf.data(), static_cast<int>(bytes), MPI_BYTE, 0, a, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        buf.front() = static_cast<unsigned char>(buf.front() + 1), buf.back() = buf.front();
        MPI_Send(buf.data(), static_cast<int>(bytes), MPI_BYTE, 0, a, MPI_COMM_WORLD);
      }
    }
    if (rank == 0) {
      std::string line = std::to_string(bytes);
      char num[32];
      for (double h : half) {
        std::snprintf(num, sizeof num, " %.6e", h);
        line += num;
      }
      std::printf("%s\n", line.c_str());
    }
  }
  MPI_Finalize();
  return status;
}
