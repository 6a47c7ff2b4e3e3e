// Cancel, pause, resume and remove-results, shared by the queue and the job page so both ask and report alike.

import { api } from '/ui/api.js';
import { shortId } from '/ui/format.js';
import { toast, toastError } from '/ui/notify.js';

// Resolves to the job's new status, or null when the request failed (already reported).
export async function cancelJob(id) {
  try {
    const job = await api.cancelJob(id);
    toast(`Job ${shortId(id)} canceled.`);
    return job;
  } catch (e) {
    toastError(e, `Could not cancel job ${shortId(id)}: `);
    return null;
  }
}

// Pause or resume: resolves to the job's new status, or null when the request failed (reported).
export async function pauseJob(id) {
  try {
    const job = await api.pauseJob(id);
    toast(`Job ${shortId(id)} paused: it keeps its samples until resumed.`);
    return job;
  } catch (e) {
    toastError(e, `Could not pause job ${shortId(id)}: `);
    return null;
  }
}

export async function resumeJob(id) {
  try {
    const job = await api.resumeJob(id);
    toast(`Job ${shortId(id)} resumed.`);
    return job;
  } catch (e) {
    toastError(e, `Could not resume job ${shortId(id)}: `);
    return null;
  }
}

// Resolves to true once the files are gone; asks first, because nothing brings them back.
export async function removeResults(id) {
  if (!window.confirm(`Delete the image, sample-rate map and report of job ${shortId(id)}? The job record stays.`)) return false;
  try {
    await api.deleteResults(id);
    toast(`Results of job ${shortId(id)} removed.`);
    return true;
  } catch (e) {
    toastError(e, `Could not remove the results of job ${shortId(id)}: `);
    return false;
  }
}
