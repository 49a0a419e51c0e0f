//! The share of the samples that one task of an array job renders: tasks
//! split `0..spp` into near-equal disjoint ranges, which `luz merge` adds up
//! again. The task comes from the command line or from the batch system's
//! environment (Slurm job arrays, Kubernetes Indexed Jobs).

use crate::echo::echo;
use std::ops::Range;

#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum TaskError {
    #[error("{from}: the task count must be at least 1")]
    NoTasks { from: &'static str },
    #[error("{from}: task index {index} is not below the task count {count}")]
    IndexNotBelowCount {
        from: &'static str,
        index: u32,
        count: u32,
    },
    #[error("{from}: {count} tasks cannot share {spp} samples per pixel")]
    MoreTasksThanSamples {
        from: &'static str,
        count: u32,
        spp: u32,
    },
    #[error("{name}: expected an unsigned integer, found {}", echo(value))]
    NotANumber { name: &'static str, value: String },
    #[error("SLURM_ARRAY_TASK_ID is set but not SLURM_ARRAY_TASK_COUNT: pass --task-count")]
    SlurmWithoutCount,
    #[error("SLURM_ARRAY_TASK_ID: {id} is not in the array {min}, {}, ...", min + step)]
    NotInArray { id: u32, min: u32, step: u32 },
    #[error("JOB_COMPLETION_INDEX is set: pass --task-count with the Job's completions")]
    KubernetesWithoutCount,
}

/// Task `index` of `count`, and where that was learnt (for messages).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Task {
    pub index: u32,
    pub count: u32,
    pub source: &'static str,
}

impl Task {
    /// The task's share of `0..spp`: range `i` is `i*spp/n .. (i+1)*spp/n`.
    pub fn range(&self, spp: u32) -> Result<Range<u32>, TaskError> {
        let (i, n) = (self.index as u64, self.count as u64);
        let from = self.source;
        if n == 0 {
            return Err(TaskError::NoTasks { from });
        }
        if i >= n {
            return Err(TaskError::IndexNotBelowCount {
                from,
                index: self.index,
                count: self.count,
            });
        }
        if n > spp as u64 {
            return Err(TaskError::MoreTasksThanSamples {
                from,
                count: self.count,
                spp,
            });
        }
        let spp = spp as u64;
        Ok((i * spp / n) as u32..((i + 1) * spp / n) as u32)
    }
}

fn number(
    env: &impl Fn(&str) -> Option<String>,
    name: &'static str,
) -> Result<Option<u32>, TaskError> {
    env(name)
        .map(|v| {
            v.trim()
                .parse()
                .map_err(|_| TaskError::NotANumber { name, value: v })
        })
        .transpose()
}

/// The task the batch system says this process is, if any: Slurm's
/// `SLURM_ARRAY_TASK_ID` (counted from `SLURM_ARRAY_TASK_MIN` in steps of
/// `SLURM_ARRAY_TASK_STEP`, out of `SLURM_ARRAY_TASK_COUNT`), or Kubernetes'
/// `JOB_COMPLETION_INDEX`, whose task count only the command line knows.
/// `count` (from `--task-count`) overrides the environment's.
pub fn from_env(
    env: impl Fn(&str) -> Option<String>,
    count: Option<u32>,
) -> Result<Option<Task>, TaskError> {
    if let Some(id) = number(&env, "SLURM_ARRAY_TASK_ID")? {
        let min = number(&env, "SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
        let step = number(&env, "SLURM_ARRAY_TASK_STEP")?.unwrap_or(1).max(1);
        let count = match count {
            Some(c) => c,
            None => number(&env, "SLURM_ARRAY_TASK_COUNT")?.ok_or(TaskError::SlurmWithoutCount)?,
        };
        if id < min || (id - min) % step != 0 {
            return Err(TaskError::NotInArray { id, min, step });
        }
        return Ok(Some(Task {
            index: (id - min) / step,
            count,
            source: "SLURM_ARRAY_TASK_ID",
        }));
    }
    if let Some(index) = number(&env, "JOB_COMPLETION_INDEX")? {
        let count = count.ok_or(TaskError::KubernetesWithoutCount)?;
        return Ok(Some(Task {
            index,
            count,
            source: "JOB_COMPLETION_INDEX",
        }));
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(vars: &'a [(&str, &str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |name| {
            vars.iter()
                .find(|(k, _)| *k == name)
                .map(|(_, v)| v.to_string())
        }
    }

    #[test]
    fn ranges_tile_the_samples_exactly() {
        for (spp, n) in [(256, 4), (10, 3), (7, 7), (1000, 13)] {
            let mut next = 0;
            for index in 0..n {
                let task = Task {
                    index,
                    count: n,
                    source: "test",
                };
                let r = task.range(spp).unwrap();
                assert_eq!(r.start, next);
                assert!(r.len() as u32 >= spp / n);
                next = r.end;
            }
            assert_eq!(next, spp);
        }
        let task = |index, count| Task {
            index,
            count,
            source: "--task-index",
        };
        assert!(task(4, 4).range(256).is_err());
        assert!(task(0, 0).range(256).is_err());
        assert!(task(0, 5).range(4).is_err());
    }

    #[test]
    fn slurm_and_kubernetes_environments() {
        let slurm = [
            ("SLURM_ARRAY_TASK_ID", "7"),
            ("SLURM_ARRAY_TASK_MIN", "5"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ];
        let task = from_env(env(&slurm), None).unwrap().unwrap();
        assert_eq!((task.index, task.count), (2, 4));
        assert_eq!(from_env(env(&slurm), Some(8)).unwrap().unwrap().count, 8);
        let stepped = [
            ("SLURM_ARRAY_TASK_ID", "4"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_STEP", "2"),
            ("SLURM_ARRAY_TASK_COUNT", "3"),
        ];
        assert_eq!(from_env(env(&stepped), None).unwrap().unwrap().index, 2);

        let k8s = [("JOB_COMPLETION_INDEX", "3")];
        assert_eq!(
            from_env(env(&k8s), None).unwrap_err(),
            TaskError::KubernetesWithoutCount
        );
        let task = from_env(env(&k8s), Some(4)).unwrap().unwrap();
        assert_eq!((task.index, task.count), (3, 4));

        assert_eq!(from_env(env(&[]), Some(4)).unwrap(), None);
        let bad = [
            ("SLURM_ARRAY_TASK_ID", "x"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ];
        assert_eq!(
            from_env(env(&bad), None).unwrap_err().to_string(),
            "SLURM_ARRAY_TASK_ID: expected an unsigned integer, found `x`"
        );
    }
}
